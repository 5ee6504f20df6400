"""`thermocue monitor`: the experimenter's live view of a session folder, as a local web page.

Also :func:`start_beside` / :func:`stop_beside`: ``thermocue run ... --monitor`` (and
``resume``) start it in a process of its own beside the session and stop it when the session
ends (or when the session's process is gone). The monitor runs at nice 10 wherever it is
started: it must never slow a session.
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys

PREFIX = "thermocue monitor"


def register(sub) -> None:
    p = sub.add_parser(
        "monitor", help="the experimenter's live view of a session, as a local web page",
        description="Serve a read-only web page that follows SESSION_FOLDER as the session writes "
                    "it (live pad temperature, force, state, trials, faults, time left); on a "
                    "finished session it browses the trials. Binds 127.0.0.1 on a free port and "
                    "prints the URL; stop it with Ctrl-C.")
    p.add_argument("folder", metavar="SESSION_FOLDER", help="DATA/<participant>/<session>")
    p.add_argument("--host", default=None, metavar="ADDR",
                   help="serve on this address instead of 127.0.0.1 (e.g. 0.0.0.0 for the lab's "
                        "network); the URL then holds a random token, and requests without it "
                        "get 403")
    p.add_argument("--port", type=int, default=0, metavar="N", help="port (default: a free one)")
    # run/resume --monitor: stop when that process is gone (even killed)
    p.add_argument("--exit-with", type=int, default=None, help=argparse.SUPPRESS)
    p.set_defaults(func=_run)


def _say(text: str) -> None:
    print(f"{PREFIX}: {text}", file=sys.stderr, flush=True)


def _run(ns) -> int:
    import asyncio

    from experiments.errors import UserInputError
    from experiments.monitor.server import Monitor, uplot_dir

    if not 0 <= ns.port <= 65535:
        raise UserInputError(f"--port: expected a port number 0-65535, got {ns.port}")
    if uplot_dir() is None:
        _say("the chart library uPlot is not installed (expected in .venv/uplot, from npm; "
             "./scripts/setup installs it, or set THERMOCUE_UPLOT_DIR to its dist folder)")
        return 1
    host = ns.host or "127.0.0.1"
    try:
        os.nice(10)        # below the session wherever it is started: it must never slow it
    except OSError:
        pass
    try:
        monitor = Monitor(ns.folder, host=host, port=ns.port, token=True if ns.host else None,
                          say=_say)
    except OSError as exc:
        _say(f"cannot serve on {host}:{ns.port} ({exc.strerror or exc})")
        return 1

    async def serve():
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        monitor.start()
        print(monitor.url, flush=True)
        note = ""
        if monitor.token is not None:
            note = " (keep the URL: its token is the key"
            if host in ("0.0.0.0", "::"):
                note += f"; from another computer put this machine's address for {host}"
            note += ")"
        _say(f"the experimenter's view of {ns.folder}: {monitor.url}{note}")
        while not stop.is_set():
            try:
                await asyncio.wait_for(stop.wait(), timeout=1.0)
            except asyncio.TimeoutError:
                if ns.exit_with is not None and os.getppid() != ns.exit_with:
                    break      # the session's process is gone
        # the session's last lines reach the open pages before the server goes: one more read
        # of the folder, then the streams' own timers (shorter than this one) send it
        monitor.poll()
        await asyncio.sleep(max(0.5, 10 * monitor.poll_s))
        monitor.stop()

    asyncio.run(serve())
    return 0


def start_beside(folder, out=sys.stderr):
    """Start ``thermocue monitor FOLDER`` in a process of its own (it lowers its own priority,
    and stops when this process is gone); it says its URL on the terminal.

    Returns the process (None when it could not start: said, and the session goes on)."""
    cmd = [sys.executable, "-m", "experiments", "monitor", str(folder),
           "--exit-with", str(os.getpid())]
    try:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True,
                                start_new_session=True)
    except OSError as exc:
        print(f"{PREFIX}: not started ({exc}); the session goes on without it", file=out, flush=True)
        return None
    url = proc.stdout.readline().strip()
    if not url:
        proc.wait()
        print(f"{PREFIX}: not started (it said why above); the session goes on without it",
              file=out, flush=True)
        return None
    return proc


def stop_beside(proc, folder, out=sys.stderr) -> None:
    """Stop the monitor started by :func:`start_beside` and say how to browse the session."""
    if proc is None:
        return
    proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    print(f"{PREFIX}: stopped with the session; browse it with `thermocue monitor {folder}`",
          file=out, flush=True)

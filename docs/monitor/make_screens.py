"""Screenshots of thermocue monitor's page: a live session, and a faulted trial browsed.

    python docs/monitor/make_screens.py [OUT_DIR]     (default OUT_DIR: docs/monitor)

Runs two short sessions against the in-process emulator and photographs the page in Debian's
headless Chromium (the browser tests' driver: /usr/bin/chromium, /usr/bin/chromedriver):

- ``live.png``: ``thermocue run --monitor`` on the real clock (two recorded touches, then two
  replayed profiles of 4 s, 1 s rewarm), taken while the third trial's profile plays;
- ``fault.png``: a session whose emulated Peltier driver sticks at full heating at 3 s of
  device time (``emulator://?clock=virtual&faults=overtemp@3``): the pad trips
  OVER_TEMPERATURE in trial 2, the latched fault makes the display refuse the next two
  attempts and the session stops; the faulted attempt is clicked in the table.
"""
from __future__ import annotations

import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
sys.path[:0] = [str(REPO / "tests" / "experiments"), str(REPO / "tests" / "experiments" / "monitor")]
from _browser import chromium, monitor_process, wait_for  # noqa: E402  (the tests' browser)
from _session_helpers import P01, write_protocol  # noqa: E402  (one protocol text)

THERMOCUE = [sys.executable, "-m", "experiments"]
STATS = "return window.monitorStats"


def _run(proto, data, display, *more, **popen):
    return subprocess.Popen([*THERMOCUE, "run", str(proto), "--participant", str(P01),
                             "--display", display, "--responder", "simulated", "--data",
                             str(data), "--seed", "1", *more], cwd=REPO, text=True, **popen)


def live_page(tmp: Path, out: Path) -> None:
    proto = write_protocol(tmp, contact_s=4.0, rewarm_s=1.0, real_samples=(1, 2),
                           sim_samples=(1, 2))
    run = _run(proto, tmp / "data", "emulator://?clock=real", "--monitor",
               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(run.stderr), daemon=True).start()
    try:
        url = wait_for(lambda: next((m[1] for m in (re.search(r"view of .*: (http://\S+)", x)
                                                      for x in lines) if m), None), what="the URL")
        with chromium() as d:
            d.get(url)
            wait_for(lambda: d.find_element("id", "state").text == "PLAYING"
                     and d.execute_script(STATS)["frames"] > 250, timeout_s=120,
                     what="a profile playing")
            time.sleep(1.5)
            d.save_screenshot(str(out / "live.png"))
        run.wait(timeout=120)
    finally:
        if run.poll() is None:
            run.kill()


def fault_page(tmp: Path, out: Path) -> None:
    proto = write_protocol(tmp, contact_s=2.0, real_samples=(1, 2), sim_samples=(1, 2))
    done = _run(proto, tmp / "data", "emulator://?clock=virtual&faults=overtemp@3", "--quiet",
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    done.wait(timeout=300)
    with monitor_process(tmp / "data" / "P01" / "S01") as (_, url), chromium() as d:
        d.get(url)
        row = wait_for(lambda: next((tr for tr in d.find_elements("css selector", "#trials tbody tr")
                                     if "OVER_TEMPERATURE" in tr.text), None), what="the fault row")
        row.click()
        wait_for(lambda: d.execute_script("return !!window.monitorCharts.picked"), what="its trace")
        d.execute_script("document.getElementById('picked').scrollIntoView()")
        time.sleep(0.5)
        d.save_screenshot(str(out / "fault.png"))


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else HERE
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
        live_page(Path(a), out)
        fault_page(Path(b), out)
    print(f"wrote {out / 'live.png'} and {out / 'fault.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

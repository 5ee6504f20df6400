"""The monitor over real HTTP on 127.0.0.1: the token rule, the local host name, read-only,
and what the terminal says of a folder it cannot read (thermocue monitor as a process)."""
from __future__ import annotations

import http.client
import re
import time
import urllib.parse

import pytest

from _browser import monitor_process
from _session_helpers import P01, ScriptedDisplay, ScriptedResponder, write_protocol
from experiments.session import create_session


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("http")
    s = create_session(write_protocol(tmp, sim_samples=()), P01, tmp / "data", "scripted://",
                       seed=7, responder_name="scripted-test", clock="virtual")
    assert s.run(ScriptedResponder(), display=ScriptedDisplay()) == 0
    return s.directory


def get(url, path, method="GET", host=None, read_stream=False):
    u = urllib.parse.urlsplit(url)
    conn = http.client.HTTPConnection(u.hostname, u.port, timeout=10)
    headers = {} if host is None else {"Host": host}
    conn.request(method, path, headers=headers)
    resp = conn.getresponse()
    body = resp.read(200) if read_stream else resp.read()
    conn.close()
    return resp.status, body, dict(resp.getheaders())


def test_with_host_every_request_needs_the_urls_token_else_403_and_nothing_else(folder):
    with monitor_process(folder, "--host", "127.0.0.1") as (_, url):
        token = re.fullmatch(r"http://127\.0\.0\.1:\d+/([\w-]{20,})/", url)[1]
        assert get(url, f"/{token}/")[0] == 200
        assert get(url, f"/{token}/uplot/uPlot.iife.min.js")[0] == 200
        assert get(url, f"/{token}/trace?file=traces/trial-001.csv")[0] == 200
        status, body, _ = get(url, f"/{token}/events", read_stream=True)
        assert status == 200 and body.startswith(b"data: {")
        wrong = token[:-1] + ("A" if token[-1] != "A" else "B")
        for path in ("/", "/events", "/trace?file=traces/trial-001.csv", "/static/monitor.js",
                     "/uplot/uPlot.iife.min.js", f"/{wrong}/", f"/{wrong}/events",
                     f"/?token={token}", f"/{token}", "/favicon.ico"):
            status, body, headers = get(url, path)
            assert (status, body) == (403, b""), path
            assert "Server" not in headers
        # read-only: nothing but GET, even with the token
        for method in ("POST", "PUT", "DELETE"):
            assert get(url, f"/{token}/events", method=method)[0] in (403, 405)


def test_without_host_it_serves_127_0_0_1_only_to_its_own_host_name(folder):
    with monitor_process(folder) as (_, url):
        assert re.fullmatch(r"http://127\.0\.0\.1:\d+/", url)
        status, body, headers = get(url, "/")
        assert status == 200 and b"the experimenter's view" in body
        assert headers["Content-Security-Policy"].startswith("default-src 'self'")
        # a page elsewhere reaching this port through a DNS name of its own (rebinding)
        assert get(url, "/", host="attacker.example")[:2] == (403, b"")
        assert get(url, "/events", host=f"attacker.example:{urllib.parse.urlsplit(url).port}")[:2] \
            == (403, b"")
        assert get(url, "/trace?file=session.json")[0] == 404       # only traces the log names
        assert get(url, "/", method="POST")[0] == 405


def test_a_missing_folder_is_one_line_on_the_terminal_and_the_page_says_it(tmp_path):
    missing = tmp_path / "P01" / "S09"
    with monitor_process(missing) as (proc, url):
        status, body, _ = get(url, "/events", read_stream=True)
        assert status == 200 and b"no such session folder" in body
    err = proc.stderr.read()
    assert f"thermocue monitor: {missing}: no such session folder" in err
    assert "Traceback" not in err


def test_the_monitors_stderr_says_the_url_and_it_stops_cleanly_on_ctrl_c(folder):
    with monitor_process(folder) as (proc, url):
        time.sleep(0.2)
    assert proc.returncode == 0
    err = proc.stderr.read()
    assert f"the experimenter's view of {folder}: {url}" in err and "Traceback" not in err


def test_a_monitor_beside_a_session_stops_when_the_sessions_process_is_killed(folder):
    # run --monitor starts it with --exit-with (its own pid): a SIGKILLed session leaves no
    # monitor serving behind it
    import os
    import signal
    import subprocess
    import sys
    parent = subprocess.Popen(
        [sys.executable, "-c",
         "import subprocess, sys\n"
         "from experiments.cli.monitor import start_beside\n"
         f"p = start_beside({str(folder)!r})\n"
         "print(p.pid, flush=True)\n"
         "import time; time.sleep(60)\n"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    monitor_pid = int(parent.stdout.readline())
    os.kill(parent.pid, signal.SIGKILL)
    parent.wait()
    end = time.monotonic() + 15
    while time.monotonic() < end:
        try:                              # gone, or a zombie its new parent has not reaped yet
            with open(f"/proc/{monitor_pid}/stat") as fh:
                if fh.read().rsplit(")", 1)[1].split()[0] == "Z":
                    break
        except FileNotFoundError:
            break
        time.sleep(0.1)
    else:
        os.kill(monitor_pid, signal.SIGKILL)
        pytest.fail("the monitor kept serving after the session's process was killed")

"""The monitor's page in a real browser (Debian's headless Chromium through Selenium): a live
emulated session on the real clock with an injected fault, and a finished session browsed."""
from __future__ import annotations

import csv
import re
import subprocess
import sys
import threading

import pytest

from _browser import ROOT, chromium, monitor_process, wait_for
from _session_helpers import P01, write_protocol

pytestmark = pytest.mark.slow

STATS = "return window.monitorStats"


def _text(d, element_id):
    return d.find_element("id", element_id).text


def _rows(d):
    return [[td.text for td in tr.find_elements("css selector", "td")]
            for tr in d.find_elements("css selector", "#trials tbody tr")]


def _click_row(d, trial, attempt):
    for tr in d.find_elements("css selector", "#trials tbody tr"):
        cells = tr.find_elements("css selector", "td")
        if cells[0].text == str(trial) and cells[1].text == str(attempt):
            tr.click()
            return
    pytest.fail(f"no row for trial {trial} attempt {attempt}")


class _Lines(threading.Thread):
    """A process's stderr lines, collected as they come."""

    def __init__(self, stream):
        super().__init__(daemon=True)
        self.stream, self.lines = stream, []
        self.start()

    def run(self):
        for line in self.stream:
            self.lines.append(line.rstrip("\n"))


def test_a_live_session_on_the_page_beside_thermocue_run(tmp_path):
    # `thermocue run --monitor` on the real clock: four recorded touches of 3 s (~15 s: the
    # browser, started once the monitor's URL is printed, took ~5 s in a loaded CI run and
    # opened after the second and last touch of an earlier version of this test)
    proto = write_protocol(tmp_path, contact_s=3.0, rewarm_s=0.5, real_samples=(1, 2, 3, 4),
                           sim_samples=())
    run = subprocess.Popen(
        [sys.executable, "-m", "experiments", "run", str(proto), "--participant", str(P01),
         "--display", "emulator://?clock=real", "--responder", "simulated",
         "--data", str(tmp_path / "data"), "--seed", "1", "--monitor"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    err = _Lines(run.stderr)
    try:
        url = wait_for(lambda: next((m[1] for m in (re.search(r"view of .*: (http://\S+)", x)
                                                      for x in err.lines) if m), None),
                       what="the monitor's URL on the session's terminal")
        with chromium() as d:
            d.get(url)
            assert "the experimenter's view: not for the participant" in \
                d.find_element("css selector", "h1").text
            # the trace grows while a trial plays: two looks at one running attempt's trace,
            # the later with 20 more frames and a later last time. The page may open late in
            # an attempt that ends before 20 more frames come (Chromium's start on a loaded
            # machine): the next attempt's trace, on the page from its start, shows it then.
            wait_for(lambda: (s := d.execute_script(STATS))["frames"] > 20
                     and _text(d, "state") == "RECORDING" and s,
                     what="a touch being recorded, with frames on the chart")
            first_look = {}

            def grown():
                title, s = d.execute_script(
                    "return [document.getElementById('live-title').textContent, "
                    "window.monitorStats]")
                if "(running)" not in title or not s["frames"]:
                    return False
                first = first_look.setdefault(title, s)
                return s["frames"] > first["frames"] + 20 and s["lastT"] > first["lastT"]
            wait_for(grown, what="the trace growing while an attempt plays")
            assert re.search(r"trial [1-4] of 4 · block real \([1-4] of 4\)", _text(d, "trial"))
            # the table fills in, and the time left is said once a trial is measured
            wait_for(lambda: len(_rows(d)) >= 1, what="a finished attempt in the table")
            wait_for(lambda: "left (measured trial durations, rewarm included)" in _text(d, "clock")
                     or "finished" in _text(d, "clock"), what="the time left")
            # on the real clock a loaded machine may fault an attempt (tracking, frames lost)
            # and the session retries it: the page shows every attempt the session wrote,
            # including the last, which the monitor sends before it stops with the session
            ended = wait_for(lambda: re.search(r"session (finished|stopped)", _text(d, "machine")),
                             timeout_s=120, what="the end of the session")[0]
            shown = wait_for(lambda: [r[:4] for r in _rows(d)], what="the table")
            code = run.wait(timeout=60)
        folder = tmp_path / "data" / "P01" / "S01"
        with open(folder / "trials.csv", newline="") as fh:
            written = [[w["trial_index"], w["attempt"], w["block"], w["status"]]
                       for w in csv.DictReader(fh)]
        assert shown == written
        assert ended == ("session finished" if code == 0 else "session stopped"), (ended, code)
        if code == 0:       # a finished session: each trial's last attempt is ok
            assert {t: s for t, _, _, s in written} == {str(t): "ok" for t in range(1, 5)}, written
        else:
            assert code == 1, code
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    err.join(timeout=5)
    assert any("thermocue monitor: stopped with the session" in x for x in err.lines)
    assert not any("Traceback" in x for x in err.lines)


def test_an_injected_fault_appears_on_the_trace_with_its_code(tmp_path):
    # the emulator's driver sticks at full heating at 3 s of device time: on the virtual clock
    # (device time independent of the machine's load) that is trial 2's touch; the monitor
    # follows the folder from before the session makes it
    proto = write_protocol(tmp_path, contact_s=2.0, real_samples=(1, 2), sim_samples=(1, 2))
    folder = tmp_path / "data" / "P01" / "S01"
    with monitor_process(folder) as (_, url), chromium() as d:
        d.get(url)
        wait_for(lambda: "no such session folder" in _text(d, "problem"), what="the wait said")
        out = subprocess.run(
            [sys.executable, "-m", "experiments", "run", str(proto), "--participant", str(P01),
             "--display", "emulator://?clock=virtual&faults=overtemp@3", "--responder",
             "simulated", "--data", str(tmp_path / "data"), "--seed", "1", "--quiet"],
            cwd=ROOT, capture_output=True, text=True, timeout=300)
        assert out.returncode == 1 and "OVER_TEMPERATURE" in out.stderr
        row = wait_for(lambda: next((r for r in _rows(d) if r[4] == "OVER_TEMPERATURE"), None),
                       what="the OVER_TEMPERATURE attempt in the table")
        assert row[:4] == ["2", "1", "real", "fault"]
        assert not d.find_element("id", "problem").is_displayed()
        wait_for(lambda: "session stopped" in _text(d, "machine"), what="the stop")
        assert re.search(r"last fault \(trial 2, attempt 3\): fault FAULT_LATCHED: the display "
                         r"refused to arm", _text(d, "fault")), _text(d, "fault")
        _click_row(d, row[0], row[1])
        marked = wait_for(lambda: d.execute_script(
            "const p = window.monitorCharts.picked; if (!p) return null;"
            "const i = p.temp.data[4].findIndex(v => v !== null);"
            "return i < 0 ? null : [p.temp.data[0][i], p.temp.data[4][i], p.temp.data[0].length,"
            " p.temp.data[4].filter(v => v !== null).length]"),
            what="the fault marked on the faulted trial's trace")
        t_s, _, frames, n_marks = marked
        assert n_marks == 1
        with open(folder / "traces" / "trial-002.attempt-1.fault.csv", newline="") as fh:
            trace = list(csv.DictReader(fh))
        assert frames == len(trace)
        first_fault = next(r for r in trace if r["state"] == "FAULT")
        assert t_s == float(first_fault["time_s"])              # where the display said FAULT
        assert "OVER_TEMPERATURE" in _text(d, "picked-title")
        assert "fault OVER_TEMPERATURE: the pad read above 44.8 °C" in _text(d, "picked-fault")
        assert "marked ● on the trace" in _text(d, "picked-fault")


def test_a_finished_session_is_browsed_and_a_damaged_log_is_said_on_the_page(tmp_path):
    proto = write_protocol(tmp_path, contact_s=1.0)
    out = subprocess.run(
        [sys.executable, "-m", "experiments", "run", str(proto), "--participant", str(P01),
         "--display", "emulator://?clock=virtual", "--responder", "simulated",
         "--data", str(tmp_path / "data"), "--seed", "1", "--quiet"],
        cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    folder = tmp_path / "data" / "P01" / "S01"
    with open(folder / "trials.csv", newline="") as fh:
        written = list(csv.DictReader(fh))
    with monitor_process(folder) as (_, url), chromium() as d:
        d.get(url)
        wait_for(lambda: len(_rows(d)) == len(written), what="every attempt of trials.csv")
        assert [r[:4] for r in _rows(d)] == [[w["trial_index"], w["attempt"], w["block"],
                                              w["status"]] for w in written]
        assert "session finished" in _text(d, "machine") and "finished" in _text(d, "clock")
        last = written[-1]
        _click_row(d, last["trial_index"], last["attempt"])
        with open(folder / last["trace_file"]) as fh:
            frames = sum(1 for _ in fh) - 1
        wait_for(lambda: d.execute_script(
            "const p = window.monitorCharts.picked; return p && p.temp.data[0].length") == frames,
            what="the clicked trial's whole trace on its chart")
        assert d.execute_script("return window.monitorCharts.picked.temp.data[2]"
                                ".filter(v => v !== null).length") == frames     # its target
    # served with --host: the page, its script, the stream and the trace all under the token
    with monitor_process(folder, "--host", "127.0.0.1") as (_, url), chromium() as d:
        d.get(url)
        wait_for(lambda: len(_rows(d)) == len(written), what="the table, under the token")
        _click_row(d, last["trial_index"], last["attempt"])
        wait_for(lambda: d.execute_script(
            "const p = window.monitorCharts.picked; return p && p.temp.data[0].length") == frames,
            what="a trace, under the token")
        assert not [e for e in d.get_log("browser") if e["level"] == "SEVERE"]
    # the same folder with a damaged line in its log: the page says so, in words
    lines = (folder / "events.jsonl").read_bytes().splitlines(keepends=True)
    lines[20] = b"{not json\n"
    (folder / "events.jsonl").write_bytes(b"".join(lines))
    with monitor_process(folder) as (proc, url), chromium() as d:
        d.get(url)
        problem = wait_for(lambda: d.find_element("id", "problem").is_displayed()
                           and _text(d, "problem"), what="the damage named on the page")
        assert "events.jsonl: line 21 is damaged" in problem
    assert "events.jsonl: line 21 is damaged" in proc.stderr.read()

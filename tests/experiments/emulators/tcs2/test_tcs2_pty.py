"""`thermocue emulator --model tcs2`: bad options are one line, exit 2; the pty serves a host."""
from __future__ import annotations

import threading

import numpy as np

from experiments.cli import main
from experiments.display import open_display
from experiments.display.safety import SafetyLimits
from experiments.emulators.pty_server import serve_tcs2 as serve


def test_bad_options_are_one_line_exit_2(capsys, tmp_path):
    assert main(["emulator", "--model", "tcs2", "--faults", "zap@1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--faults" in err and "zap@1" in err
    assert main(["emulator", "--model", "tcs2", "--clock", "virtual"]) == 2
    assert "--clock" in capsys.readouterr().err
    assert main(["emulator", "--speed", "5"]) == 2          # the thermocue emulator: no --speed
    assert "--speed" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_the_pty_serves_a_trial_in_real_time(tmp_path):
    link = tmp_path / "tcs2"
    ready, stop = threading.Event(), threading.Event()
    th = threading.Thread(target=serve, kwargs=dict(link=str(link), speed=4.0,
                                                    announce=lambda p: ready.set(),
                                                    stop=stop.is_set), daemon=True)
    th.start()
    assert ready.wait(10)
    try:
        t = np.arange(201) * 0.01
        with open_display(f"tcs2://{link}", SafetyLimits()) as d:
            assert d.info.firmware.endswith("thermocue-emulator")
            r = d.upload_profile(t, np.interp(t, [0, 1, 2], [32.0, 30.0, 30.0]))
            d.arm()
            rec = d.run_trial()
        assert r.segments == 2 and rec.status == "ok" and rec.frames == 200
    finally:
        stop.set()
        th.join(5)
    assert not link.exists()

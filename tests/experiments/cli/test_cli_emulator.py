from experiments.cli import main


def test_bad_fault_spec_is_a_user_error(capsys):
    assert main(["emulator", "--faults", "melt"]) == 2
    err = capsys.readouterr().err
    assert "--faults" in err and "'melt'" in err and len(err.strip().splitlines()) == 1


def test_help_names_the_options(capsys):
    import pytest
    with pytest.raises(SystemExit):
        main(["emulator", "--help"])
    out = capsys.readouterr().out
    for opt in ("--link", "--faults", "--clock", "--log"):
        assert opt in out


def test_a_second_emulator_is_refused_the_link_a_running_one_holds(tmp_path):
    """a second ``thermocue emulator --link PATH`` silently took the first one's link and
    deleted it on exit."""
    import os
    import subprocess
    import sys
    import time

    link = tmp_path / "thermo"
    cmd = [sys.executable, "-m", "experiments", "emulator", "--link", str(link)]
    first = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 20
        while not link.is_symlink():
            assert first.poll() is None and time.monotonic() < deadline, first.stderr.read()
            time.sleep(0.05)
        target = os.readlink(link)
        second = subprocess.run(cmd, capture_output=True, text=True, timeout=30)
        assert second.returncode == 2
        assert second.stderr == (f"thermocue emulator: --link {link}: expected a path no running "
                                 f"emulator holds, got the link of emulator process {first.pid} "
                                 f"(stop it, or choose another --link)\n")
        assert os.readlink(link) == target and first.poll() is None     # untouched, still serving
    finally:
        first.terminate()
        first.communicate(timeout=10)
    assert not link.exists() and not (tmp_path / "thermo.lock").exists()
    # Once the first has gone, the path is free again (a killed one's stale link is replaced).
    os.symlink("/nonexistent", link)
    third = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 20
        while not (link.is_symlink() and os.readlink(link) != "/nonexistent"):
            assert third.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        third.terminate()
        third.communicate(timeout=10)

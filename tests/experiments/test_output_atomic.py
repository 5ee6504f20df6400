"""Outputs whole or not at all, COMPLETE last: a real full tmpfs, a real RLIMIT_FSIZE, a real
read-only mount, for export-bids, analyze, power, reproduce (calibrate's writers are the same
helper: sessionfiles.atomicfile)."""
from __future__ import annotations

import contextlib
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from sessionfiles.atomicfile import COMPLETE_NAME, OutputFolder, atomic_file, atomic_path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from fuzz_session_folders import make_sessions, run_forked  # noqa: E402


@contextlib.contextmanager
def tmpfs(path: Path, size: str, readonly: bool = False):
    """A real tmpfs of ``size`` at ``path`` (root only; skipped, saying why, where it cannot be)."""
    path.mkdir(parents=True, exist_ok=True)
    options = f"size={size}" + (",ro" if readonly else "")
    run = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                         capture_output=True, text=True)
    if run.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({run.stderr.strip() or run.returncode}): the "
                    f"disk-full cases need one")
    try:
        yield path
    finally:
        subprocess.run(["umount", "-l", str(path)], check=False)


class Run:
    def __init__(self, returncode, stdout, stderr):
        self.returncode, self.stdout, self.stderr = returncode, stdout, stderr


_RUNS = iter(range(10**6))


def thermocue(args, *, fsize: int | None = None, timeout: float = 600):
    """``thermocue ARGS`` in a process of its own, forked from this one (optionally under
    RLIMIT_FSIZE, SIGXFSZ ignored so that a write past it fails with EFBIG, not a kill)."""
    import tempfile
    logs = Path(tempfile.mkdtemp(prefix="thermocue-run-"))
    how, status, out, err = run_forked(list(args), logs / str(next(_RUNS)), timeout, fsize=fsize)
    shutil.rmtree(logs, ignore_errors=True)
    assert how == "exit", f"{args}: no answer within {timeout} s"
    return Run(status, out, err)


def _no_partial(out: Path) -> None:
    """Nothing left looking complete: no COMPLETE, no temporary file."""
    assert not (out / COMPLETE_NAME).exists()
    assert [p for p in out.rglob("*") if ".tmp" in p.name] == []


def _complete(out: Path) -> dict:
    manifest = json.loads((out / COMPLETE_NAME).read_text("utf-8"))
    for name, size in manifest["files"].items():
        assert (out / name).stat().st_size == size, name
    return manifest


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    return make_sessions(tmp_path_factory.mktemp("atomic"))


# --------------------------------------------------------------------------- the helper
def test_a_failed_write_leaves_the_old_file_and_names_the_target(tmp_path):
    target = tmp_path / "table.csv"
    target.write_text("old\n")
    with pytest.raises(OSError) as err:
        with atomic_file(target) as fh:
            fh.write("new, half")
            raise OSError(28, "No space left on device")       # as a write() raises it: no name
    assert err.value.filename == str(target) and err.value.errno == 28
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]
    with atomic_path(tmp_path / "figure.png") as tmp:
        assert tmp.suffix == ".png" and tmp.parent == tmp_path     # a writer choosing by suffix
        tmp.write_bytes(b"png")
    assert (tmp_path / "figure.png").read_bytes() == b"png"


def test_complete_is_removed_first_and_written_last(tmp_path):
    folder = OutputFolder(tmp_path / "out", "test")
    out = folder.begin()
    (out / "a.csv").write_text("x\n")
    folder.finish([out / "a.csv"])
    assert _complete(out)["files"] == {"a.csv": 2}
    folder.begin()
    assert not (out / COMPLETE_NAME).exists() and (out / "a.csv").exists()


# --------------------------------------------------------------------------- disk full
def test_export_bids_on_a_full_disk_then_after_freeing_space(data, tmp_path):
    with tmpfs(tmp_path / "disk", "200k") as disk:
        filler = disk / "filler"
        filler.write_bytes(b"\0" * 150_000)
        out = disk / "bids"
        run = thermocue(["export-bids", str(data), "--out", str(out)])
        assert run.returncode == 1, run.stderr
        line = run.stderr.strip()
        assert "\n" not in line and "Traceback" not in run.stderr
        assert line.startswith(f"thermocue export-bids: {out}/") and \
            line.endswith(": No space left on device"), line
        _no_partial(out)
        filler.unlink()                                   # space freed: the rerun succeeds
        run = thermocue(["export-bids", str(data), "--out", str(out)])
        assert run.returncode == 0, run.stderr
        files = _complete(out)["files"]
        assert "sub-P01/ses-S01/beh/sub-P01_ses-S01_task-roughnessrecognition_beh.tsv" in files
        assert "sub-P02/ses-S01/beh/sub-P02_ses-S01_task-roughnessrecognition_beh.tsv" in files


@pytest.mark.slow
def test_analyze_on_a_full_disk_then_after_freeing_space(data, tmp_path):
    with tmpfs(tmp_path / "disk", "1m") as disk:      # the outputs take ~300 kB
        filler = disk / "filler"
        filler.write_bytes(b"\0" * 850_000)           # ~170 kB left
        out = disk / "results"
        args = ["analyze", str(data), "--out", str(out), "--bootstrap", "0", "--no-mixed", "--quiet"]
        run = thermocue(args)
        assert run.returncode == 1, run.stderr
        line = run.stderr.strip().splitlines()[-1]
        assert "Traceback" not in run.stderr
        assert line.startswith(f"thermocue analyze: {out}/") and \
            line.endswith(": No space left on device"), line
        _no_partial(out)
        filler.unlink()
        run = thermocue(args)
        assert run.returncode == 0, run.stderr
        files = _complete(out)["files"]
        assert {"report.md", "figure9.png", "figure9.pdf", "all_trials.csv"} <= set(files)


# --------------------------------------------------------------------------- file too large
@pytest.mark.parametrize("command", [
    ["export-bids", "{data}", "--out", "{out}"],
    ["reproduce", "table2", "--out", "{out}"],
])
def test_file_too_large_is_one_line_and_nothing_looks_complete(data, tmp_path, command):
    out = tmp_path / "out"
    args = [a.format(data=data, out=out) for a in command]
    run = thermocue(args, fsize=1500)          # RLIMIT_FSIZE: every file past 1.5 kB fails
    assert run.returncode == 1, run.stderr
    line = run.stderr.strip().splitlines()[-1]
    assert "Traceback" not in run.stderr
    assert line.startswith(f"thermocue {args[0]}: {out}/") and line.endswith(": File too large"), line
    _no_partial(out)
    run = thermocue(args)                      # the limit lifted: the rerun succeeds
    assert run.returncode == 0, run.stderr
    _complete(out)


@pytest.mark.slow
@pytest.mark.parametrize("command", [
    ["analyze", "{data}", "--out", "{out}", "--bootstrap", "0", "--no-mixed", "--quiet"],
    ["power", "--out", "{out}", "--simulations", "20", "--n-per-group", "5"],
    ["reproduce", "figures", "--out", "{out}"],
])
def test_file_too_large_for_the_slower_commands(data, tmp_path, command):
    out = tmp_path / "out"
    args = [a.format(data=data, out=out) for a in command]
    run = thermocue(args, fsize=20_000)
    assert run.returncode == 1, run.stderr
    line = run.stderr.strip().splitlines()[-1]
    assert "Traceback" not in run.stderr
    assert line.startswith(f"thermocue {args[0]}: {out}/") and line.endswith(": File too large"), line
    _no_partial(out)


# --------------------------------------------------------------------------- read-only
def test_a_read_only_output_folder_is_named_before_any_work(data, tmp_path):
    with tmpfs(tmp_path / "ro", "100k", readonly=True) as ro:
        for args in (["export-bids", str(data), "--out", str(ro / "bids")],
                     ["analyze", str(data), "--out", str(ro / "a"), "--quiet"]):
            run = thermocue(args)
            assert run.returncode == 2, run.stderr
            assert run.stderr.strip() == (f"thermocue {args[0]}: --out {ro / args[3].split('/')[-1]}: "
                                          f"expected a folder it can write in, got Read-only file "
                                          f"system ({ro})")
        assert list(ro.iterdir()) == []


def test_a_read_only_folder_met_while_writing_is_one_line(data, tmp_path):
    out = tmp_path / "bids"
    (out / "sub-P02").mkdir(parents=True)
    with tmpfs(out / "sub-P02", "100k", readonly=True):   # writable --out, read-only inside
        run = thermocue(["export-bids", str(data), "--out", str(out)])
        assert run.returncode == 1, run.stderr
        assert run.stderr.strip().startswith(f"thermocue export-bids: {out / 'sub-P02'}")
        assert run.stderr.strip().endswith(": Read-only file system")
        _no_partial(out)


@pytest.mark.slow
def test_calibrate_file_too_large_then_a_rerun(tmp_path):
    from _calibration_helpers import make_session
    sdir = make_session(tmp_path / "DATA")
    out = tmp_path / "cal"
    args = ["calibrate", str(sdir), "--out", str(out), "--sample-thickness-um", "3000"]
    run = thermocue(args, fsize=2000)           # residuals.png and fit.json are larger
    assert run.returncode == 1, run.stderr
    line = run.stderr.strip().splitlines()[-1]
    assert "Traceback" not in run.stderr
    assert line.startswith(f"thermocue calibrate: {out}/") and line.endswith(": File too large"), line
    _no_partial(out)
    run = thermocue(args)
    assert run.returncode == 0, run.stderr
    assert {"residuals.png", "resistances.csv", "skin.csv", "parameters.md", "fit.json"} <= \
        set(_complete(out)["files"])

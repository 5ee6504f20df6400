"""Damaged session folders through ``thermocue analyze`` and ``thermocue export-bids``.  Not a test
(its short form is: ``tests/experiments/test_fuzz_session_folders.py``).

Run:  .venv/bin/python benchmarks/fuzz_session_folders.py [--cases 300] [--seed 1] [--jobs 2]
                                                          [--keep DIR]

Real sessions first: two participants (P01, group A; P02, group B) through a short
``roughness_recognition`` (0.5 s contacts, one repetition: 12 trials, 4 of them familiarisation) on
the emulated display on its virtual clock, with an answering responder that is wrong on every
third trial. Then each case is a data folder holding copies of both sessions with one to three
kinds of damage applied to a random file of a random session:

truncation (a random cut, an empty file, a power cut's NUL fill), byte flips, a deleted file or
``traces/``, a duplicated line, a copied participant folder (as a backup), another session's
``session.json``, another encoding (UTF-16 with and without a byte-order mark, Latin-1, a UTF-8
byte-order mark: accepted), a special file in a file's place (a FIFO, a symbolic link to
``/dev/zero`` or ``/dev/urandom``, a folder, a socket), a sparse file past the size bound, and
impossible values in ``trials.csv`` or the log (status ``ol``, response 7, ``correct`` not the
answer's, ``rt_s`` -3 / 1e999 / nan, roughness -1.6, a NUL byte, trial 0, another participant id).

Each command runs in a process of its own (forked from one that imported thermocue once) under a
time-out (``--timeout-s``, default 120 s) and is classified:

* ``traceback``: an exception escaped ``main`` (or "Traceback" on stderr), or an exit status
  other than 0, 1, 2;
* ``hang``: killed at the time-out;
* ``refused``/``fs_error``: exit 2/1 with one line naming a file under the case folder;
  ``unnamed``: exit 1/2 whose last line names no such path;
* ``ok``: exit 0, and every session folder of the case is *accounted for*: its session is in the
  output (``sessions.csv``'s paths; the BIDS ``sub-<id>/ses-<n>``), or its path is named on
  stderr, stdout or in ``report.md``; otherwise ``silent_drop``. An exported TSV holding another
  participant's or session's rows, or a ``sub-None``, counts as ``misfiled``.

Prints one line per case (``--verbose``) and the counts per command and outcome, and exits 1 if
any traceback, hang, unnamed refusal, silent drop or misfiled row was found.
"""
from __future__ import annotations

import argparse
import csv
import io
import json
import os
import random
import re
import shutil
import signal
import socket
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

BAD_CELLS = [("status", "ol"), ("response_id", "7"), ("rt_s", "-3"), ("rt_s", "1e999"),
             ("rt_s", "nan"), ("roughness_um", "-1.6"), ("participant", "P0\x001"),
             ("trial_index", "0"), ("participant", "P99"), ("session", "S77"),
             ("correct", "flip"), ("roughness_id", "9"), ("tracking_rms_C", "-0.5"),
             ("contact_force_N", "inf")]
KINDS = ("truncate", "empty", "nul_tail", "flip", "delete", "delete_traces", "dup_line",
         "copy_folder", "swap_meta", "utf16", "utf16_nobom", "latin1", "utf8_bom", "fifo",
         "dev_zero", "dev_urandom", "folder", "socket", "huge", "bad_cell", "bad_event_value")


# --------------------------------------------------------------------------- real sessions
def make_sessions(folder: Path) -> Path:
    """Two real emulated sessions (virtual clock) under ``folder/data``; returns it."""
    from importlib.resources import files

    from experiments.responders.base import Responder, Response
    from experiments.session import create_session

    class Answers(Responder, name="fuzz-answers"):
        human = False

        def respond(self, trial, stimulus):
            r = trial.roughness_id
            return Response(r if trial.trial_index % 3 else r % 4 + 1, 0.4 + 0.01 * r,
                            source="fuzz")

    text = (files("experiments") / "protocols" / "roughness_recognition.toml").read_text("utf-8")
    for key in ("max_contact_s", "record_s", "duration_s"):
        text = re.sub(rf"^{key} = 20\.0", f"{key} = 0.5", text, flags=re.M)
    text = re.sub(r"^repetitions = 3", "repetitions = 1", text, flags=re.M)
    folder.mkdir(parents=True, exist_ok=True)
    proto = folder / "short.toml"
    proto.write_text(text, encoding="utf-8")
    data = folder / "data"
    for i, pid in enumerate(("P01", "P02")):
        s = create_session(proto, ROOT / "participants" / "examples" / f"{pid}.json", data,
                           "emulator://?clock=virtual&seed=1", seed=i,
                           responder_name="fuzz-answers", clock="virtual")
        status = s.run(Answers())
        if status != 0:
            raise SystemExit(f"fuzz: the base session of {pid} ended with {status}")
    shutil.rmtree(data / "bids", ignore_errors=True)     # the sessions' own export: not input
    return data


# --------------------------------------------------------------------------- damage
def _files(session: Path) -> list[Path]:
    names = [session / n for n in ("session.json", "events.jsonl", "trials.csv")]
    traces = sorted((session / "traces").glob("*.csv")) if (session / "traces").is_dir() else []
    small = lambda p: p.is_file() and p.stat().st_size < (10 << 20)   # noqa: E731 - not "huge"
    return [p for p in names + traces[:1] if small(p)]


def _set_cell(path: Path, rng: random.Random, column: str, value: str) -> str:
    if path.stat().st_size > (10 << 20):
        return "not a table (huge)"
    with open(path, newline="", encoding="utf-8", errors="replace") as fh:
        rows = [r for r in csv.reader(fh) if r]
    if len(rows) < 2 or column not in rows[0] or "response_id" not in rows[0]:
        return "no such column"
    j, k = rows[0].index(column), rows[0].index("response_id")
    answered = [i for i in range(1, len(rows)) if len(rows[i]) > max(j, k) and rows[i][k]]
    if not answered:
        return "no answered row"
    i = rng.choice(answered or list(range(1, len(rows))))
    if value == "flip":
        value = "0" if rows[i][j] == "1" else "1"
    rows[i][j] = value
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    path.write_text(buf.getvalue(), encoding="utf-8")
    return f"line {i + 1}"


def _copy_any(src, dst) -> None:
    """Copy a file; a FIFO or socket (damage already applied) becomes a FIFO."""
    import stat
    mode = os.lstat(src).st_mode
    if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):
        os.mkfifo(dst)
    else:
        shutil.copy2(src, dst)


def _truncate(target: Path, rng: random.Random) -> None:
    raw = target.read_bytes()
    target.write_bytes(raw[:rng.randrange(0, max(1, len(raw)))])


def _nul_tail(target: Path, rng: random.Random) -> None:
    raw = target.read_bytes()
    cut = rng.randrange(0, max(1, len(raw)))
    target.write_bytes(raw[:cut] + b"\x00" * rng.randrange(1, 4096))


def _flip(target: Path, rng: random.Random) -> None:
    raw = bytearray(target.read_bytes())
    for _ in range(rng.randrange(1, 6)):
        if raw:
            raw[rng.randrange(len(raw))] ^= 1 << rng.randrange(8)
    target.write_bytes(bytes(raw))


def _dup_line(target: Path, rng: random.Random) -> None:
    lines = target.read_bytes().splitlines(keepends=True)
    if len(lines) > 1:
        i = rng.randrange(1, len(lines))
        lines.insert(i, lines[i])
    target.write_bytes(b"".join(lines))


def _latin1(target: Path, rng: random.Random) -> None:
    text = target.read_text("utf-8", errors="replace")
    at = text.find("\n", len(text) // 3) + 1
    target.write_bytes(text[:at].encode("utf-8", errors="replace")
                       + text[at:].replace("a", "\u00e9", 1).encode("latin-1", errors="replace"))


#: The damages done to one existing file's bytes (a missing file is deleted instead).
_FILE_DAMAGE = {
    "truncate": _truncate,
    "empty": lambda target, rng: target.write_bytes(b""),
    "nul_tail": _nul_tail,
    "flip": _flip,
    "dup_line": _dup_line,
    "utf16": lambda target, rng: target.write_bytes(
        target.read_text("utf-8", errors="replace").encode("utf-16")),
    "utf16_nobom": lambda target, rng: target.write_bytes(
        target.read_text("utf-8", errors="replace").encode("utf-16-le")),
    "latin1": _latin1,
    "utf8_bom": lambda target, rng: target.write_bytes(b"\xef\xbb\xbf" + target.read_bytes()),
}


def _special_file(kind: str, session: Path, data: Path, rng: random.Random) -> Path:
    """One of the session's three files replaced by a FIFO, a link to /dev/zero or /dev/urandom,
    a folder, a socket or a sparse 300 MB file; returns its path under ``data``."""
    target = rng.choice([session / n for n in ("session.json", "events.jsonl", "trials.csv")])
    if target.is_dir():
        shutil.rmtree(target)
    else:
        target.unlink(missing_ok=True)
    if kind == "fifo":
        os.mkfifo(target)
    elif kind == "dev_zero":
        os.symlink("/dev/zero", target)
    elif kind == "dev_urandom":
        os.symlink("/dev/urandom", target)
    elif kind == "folder":
        target.mkdir()
    elif kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        try:
            s.bind(str(target))
        except OSError:            # a path too long for a socket: a FIFO instead
            os.mkfifo(target)
        s.close()
    else:
        with open(target, "wb") as fh:     # sparse: 300 MB that cost no disk
            fh.truncate(300 << 20)
    return target.relative_to(data)


def _bad_event_value(session: Path, data: Path, rng: random.Random) -> str:
    """A bad value in the first answered trial_completed row of the log, trials.csv removed
    (the log is then the table); returns what was done."""
    kind = "bad_event_value"
    path = session / "events.jsonl"
    if not path.is_file() or path.stat().st_size > (10 << 20):
        return f"{kind}: no events.jsonl in {session.relative_to(data)}"
    column, value = rng.choice(BAD_CELLS)
    out = []
    done = False
    for line in path.read_text("utf-8", errors="replace").splitlines(keepends=True):
        if not done and '"trial_completed"' in line:
            try:
                ev = json.loads(line)
            except ValueError:
                out.append(line)
                continue
            if isinstance(ev.get("row"), dict) and ev["row"].get("response_id") is not None:
                ev["row"][column] = value
                line = json.dumps(ev) + "\n"
                done = True
        out.append(line)
    path.write_text("".join(out), encoding="utf-8")
    (session / "trials.csv").unlink(missing_ok=True)       # the log is then the table
    return f"{kind} {column}={value!r} in {session.relative_to(data)}/events.jsonl"


def _session_damage(kind: str, session: Path, sessions: list, data: Path,
                    rng: random.Random) -> str:
    """A damage to the session as a whole (not one file's bytes); returns what was done."""
    if kind == "delete_traces":
        shutil.rmtree(session / "traces", ignore_errors=True)
        return f"{kind} {Path(session.relative_to(data), 'traces')}"
    if kind == "copy_folder":
        name = rng.choice([f"{session.parent.name} copy", "backup", "P03"])
        shutil.copytree(session.parent, data / name, symlinks=True, copy_function=_copy_any)
        return f"{kind} {Path(name)}"
    if kind == "swap_meta":
        other = next((s for s in sessions if s != session), None)
        if other is not None and (other / "session.json").is_file():
            shutil.copy(other / "session.json", session / "session.json")
        return f"{kind} {session.relative_to(data) / 'session.json'}"
    if kind == "bad_cell":
        column, value = rng.choice(BAD_CELLS)
        where = _set_cell(session / "trials.csv", rng, column, value) \
            if (session / "trials.csv").is_file() else "no trials.csv"
        return f"{kind} {column}={value!r} ({where}) in {session.relative_to(data)}/trials.csv"
    if kind == "bad_event_value":
        return _bad_event_value(session, data, rng)
    return f"{kind} {_special_file(kind, session, data, rng)}"


def damage(data: Path, rng: random.Random) -> list[str]:
    """Apply one kind of damage to a random session under ``data``; return what was done."""
    sessions = sorted(p.parent for p in data.glob("*/*/session.json")) or \
        sorted(p for p in data.glob("*/*") if p.is_dir())
    session = rng.choice(sessions)
    kind = rng.choice(KINDS)
    files = _files(session)
    target = rng.choice(files) if files else session / "trials.csv"
    if kind in _FILE_DAMAGE and not target.is_file():
        kind = "delete"
    if kind == "delete":
        target.unlink(missing_ok=True)
    elif kind in _FILE_DAMAGE:
        _FILE_DAMAGE[kind](target, rng)
    else:
        return [_session_damage(kind, session, sessions, data, rng)]
    return [f"{kind} {target.relative_to(data)}"]


# --------------------------------------------------------------------------- runs
def run_forked(args: list[str], out: Path, timeout_s: float,
               fsize: int | None = None) -> tuple[str, int | None, str, str]:
    """Run ``thermocue ARGS`` in a forked child; ``(how, status, stdout, stderr)``.

    ``how`` is ``"exit"`` or ``"hang"`` (killed after ``timeout_s``); ``fsize``: the child's
    RLIMIT_FSIZE in bytes (SIGXFSZ ignored, so a write past it fails with EFBIG)."""
    from experiments.cli import main
    out.mkdir(parents=True, exist_ok=True)
    so, se = out / "stdout.txt", out / "stderr.txt"
    pid = os.fork()
    if pid == 0:                                    # the child: never returns
        status = 98
        try:
            os.setsid()
            fd1 = os.open(so, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
            fd2 = os.open(se, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
            os.dup2(fd1, 1)
            os.dup2(fd2, 2)
            sys.stdout = io.TextIOWrapper(os.fdopen(1, "wb", closefd=False), line_buffering=True)
            sys.stderr = io.TextIOWrapper(os.fdopen(2, "wb", closefd=False), line_buffering=True)
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            if fsize is not None:
                import resource
                signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
                resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))
            status = main(args)
        except SystemExit as exc:
            status = exc.code if isinstance(exc.code, int) else 2
        except BaseException:                       # a traceback: what the fuzz hunts
            import traceback
            traceback.print_exc()
            status = 99
        finally:
            try:
                sys.stdout.flush()
                sys.stderr.flush()
            finally:
                os._exit(int(status))
    deadline = time.monotonic() + timeout_s
    how, status = "exit", None
    while True:
        done, code = os.waitpid(pid, os.WNOHANG)
        if done:
            status = os.waitstatus_to_exitcode(code)
            break
        if time.monotonic() > deadline:
            os.killpg(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            how = "hang"
            break
        time.sleep(0.02)
    read = lambda p: p.read_text("utf-8", errors="replace") if p.exists() else ""   # noqa: E731
    return how, status, read(so), read(se)


def _session_folders(data: Path) -> list[Path]:
    names = ("session.json", "events.jsonl", "trials.csv")
    return sorted({Path(h) for h, dirs, files in os.walk(data)
                   if set(files) & set(names) or set(dirs) & set(names)})


def _identity(folder: Path, base_ids: dict) -> tuple[str, str]:
    return base_ids.get(folder.name + "@" + folder.parent.name, (folder.parent.name, folder.name))


def classify(cmd: str, case: Path, data: Path, out: Path, how: str, status, stdout: str,
             stderr: str, given: list[Path], ids: dict) -> tuple[str, str]:
    """``(outcome, detail)`` for one run (see the module's docstring)."""
    if how == "hang":
        return "hang", f"killed after the time-out; stderr {stderr[-200:]!r}"
    if status not in (0, 1, 2) or "Traceback" in stderr:
        return "traceback", stderr.strip().splitlines()[-1] if stderr.strip() else f"status {status}"
    if status in (1, 2):
        last = stderr.strip().splitlines()[-1] if stderr.strip() else ""
        named = last.startswith(f"thermocue {cmd}: ") and str(case) in last
        return ("refused" if status == 2 else "fs_error") if named else "unnamed", last
    text = stdout + stderr
    report = out / "report.md"
    if report.exists():
        text += report.read_text("utf-8", errors="replace")
    missing = []
    if cmd == "analyze":
        with open(out / "sessions.csv", newline="", encoding="utf-8") as fh:
            analysed = {r["path"] for r in csv.DictReader(fh)}
        for folder in given:
            if str(folder) not in analysed and str(folder) not in text:
                missing.append(str(folder))
        return ("silent_drop", ", ".join(missing)) if missing else ("ok", "")
    # export-bids
    if (out / "sub-None").exists():
        return "misfiled", "sub-None written"
    for tsv in out.glob("sub-*/ses-*/beh/*_beh.tsv"):
        sub, ses = tsv.parts[-4][4:], tsv.parts[-3][4:]
        with open(tsv, newline="", encoding="utf-8") as fh:
            for row in csv.DictReader(fh, delimiter="\t"):
                if row.get("participant") not in (sub, "n/a") or row.get("session") not in (ses, "n/a"):
                    return "misfiled", f"{tsv}: {row.get('participant')}/{row.get('session')}"
    for folder in given:
        sub, ses = _identity(folder, ids)
        if not (out / f"sub-{re.sub('[^A-Za-z0-9]', '', sub)}" / f"ses-{ses}").is_dir() \
                and str(folder) not in text:
            missing.append(str(folder))
    return ("silent_drop", ", ".join(missing)) if missing else ("ok", "")


def _prepare(i: int, work: Path, base: Path, rng: random.Random) -> tuple:
    case = work / f"case-{i:04d}"
    data = case / "data"
    shutil.copytree(base, data, symlinks=True, copy_function=_copy_any)
    done = []
    for _ in range(rng.choice((1, 1, 1, 2, 3))):
        done += damage(data, rng)
    return i, case, data, done, _session_folders(data)


def _run_case(task: tuple) -> list:
    """Both commands on one prepared case: ``[(cmd, outcome, line)]``."""
    i, case, data, done, given, ids, timeout_s = task
    results = []
    for cmd, args, out in (
            ("analyze", ["analyze", str(data), "--out", str(case / "analysis"), "--bootstrap",
                         "0", "--no-mixed", "--quiet"], case / "analysis"),
            ("export-bids", ["export-bids", str(data), "--out", str(case / "bids")],
             case / "bids")):
        how, status, so, se = run_forked(args, case / f"run-{cmd}", timeout_s)
        outcome, detail = classify(cmd, case, data, out, how, status, so, se, given, ids)
        results.append((cmd, outcome, f"case {i:4d} {cmd:11s} {outcome:11s} {'; '.join(done)} | "
                                      f"{detail[:200]}"))
    if all(o in ("ok", "refused", "fs_error") for _, o, _ in results):
        shutil.rmtree(case, ignore_errors=True)         # keep only the cases that failed
    return results


#: Outcomes that fail the fuzz.
BAD = ("traceback", "hang", "unnamed", "silent_drop", "misfiled")


def run_fuzz(n_cases: int, seed: int, work: Path, timeout_s: float = 120.0, jobs: int = 1,
             verbose: bool = False, report=print) -> dict:
    """Make the sessions, damage ``n_cases`` copies, run both commands on each; return counts.

    The damage is drawn in order from ``seed`` (the same cases whatever ``jobs``); with
    ``jobs`` > 1 the cases run in that many worker processes, each forking one child per run.
    """
    import analysis.report  # noqa: F401 - imported once, before the forks
    import matplotlib
    matplotlib.use("Agg")
    base = make_sessions(work / "base")
    ids = {f"{s.name}@{s.parent.name}": (s.parent.name, s.name) for s in base.glob("*/*")}
    rng = random.Random(seed)
    tasks = [(*_prepare(i, work, base, rng), ids, timeout_s) for i in range(n_cases)]
    kinds: Counter = Counter(d.split()[0] for t in tasks for d in t[3])
    counts: Counter = Counter()
    problems = []
    t0 = time.monotonic()
    if jobs <= 1:
        results = map(_run_case, tasks)
    else:
        import multiprocessing
        pool = multiprocessing.get_context("fork").Pool(jobs)
        results = pool.imap(_run_case, tasks)
    for case_results in results:
        for cmd, outcome, line in case_results:
            counts[(cmd, outcome)] += 1
            if outcome in BAD:
                problems.append(line)
                report(line)
            elif verbose:
                report(line)
    if jobs > 1:
        pool.close()
        pool.join()
    return {"counts": counts, "kinds": kinds, "problems": problems,
            "seconds": time.monotonic() - t0, "cases": n_cases}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=300)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1,
                    help="worker processes running cases at once (default 1)")
    ap.add_argument("--timeout-s", type=float, default=120.0)
    ap.add_argument("--keep", default=None, metavar="DIR",
                    help="work in DIR (kept; failed cases stay there) instead of a temporary folder")
    ap.add_argument("--verbose", action="store_true", help="one line per run")
    ns = ap.parse_args(argv)
    work = Path(ns.keep) if ns.keep else Path(tempfile.mkdtemp(prefix="thermocue-fuzz-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        result = run_fuzz(ns.cases, ns.seed, work, ns.timeout_s, ns.jobs, ns.verbose)
    finally:
        if not ns.keep:
            shutil.rmtree(work, ignore_errors=True)
    print(f"{result['cases']} damaged session folders, seed {ns.seed}, "
          f"{result['seconds']:.0f} s; damage applied: "
          + ", ".join(f"{k} {v}" for k, v in sorted(result["kinds"].items())))
    for cmd in ("analyze", "export-bids"):
        row = {o: result["counts"].get((cmd, o), 0) for o in
               ("ok", "refused", "fs_error", "traceback", "hang", "unnamed", "silent_drop",
                "misfiled")}
        print(f"{cmd:11s} " + "  ".join(f"{k} {v}" for k, v in row.items()))
    return 1 if result["problems"] else 0


if __name__ == "__main__":
    sys.exit(main())

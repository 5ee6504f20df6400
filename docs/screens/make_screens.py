"""Screenshots of every state of the participant's and the experimenter's windows, on the real clock.

    python docs/screens/make_screens.py [OUT_DIR] [--keep DIR]   (default OUT_DIR: docs/screens)

``--keep DIR`` keeps both sessions' folders (events.jsonl, trials.csv, the draws) in DIR.

Runs two short sessions of ``thermocue run --responder psychopy --experimenter-screen 0``
against ``thermocue emulator`` (a separate process on a real pty, so the real clock) under Xvfb
(started here when ``DISPLAY`` is not set; ``xdotool`` sends the keys as real X events):

- ``keyed``: the participant reads and keys the answers (``answer_mode = "keyed"``);
- ``spoken``: the paper's procedure (``answer_mode = "spoken"``): the participant's window stays
  blank, the experimenter keys the spoken answer, confirms it, and once undoes a wrong key.

The protocol is written here (:data:`PROTOCOL`): the four samples of ``roughness_recognition``,
one trial per block (familiarise, practice with feedback, real, simulated), contacts of 2 s, a
3 s rewarm, and the ``[presentation]`` defaults written out. Every ``TextStim.draw`` in either
window is watched (the real method still draws): the back buffer is saved just after the first
draw of each text (``win.getMovieFrame(buffer='back')``; the front buffer reads back black under
Xvfb). The participant's on-screen times are the window's own ``text_on``/``text_off`` events
(PsychoPy's flip times, ``core.getTime()`` s, in ``events.jsonl``). The experimenter's window
logs no flips: its lines' times are from one draw (each draw is followed by its flip) to the
draw that replaced them. Writes ``<state>.png`` per state and ``README.md`` with the table.
"""
from __future__ import annotations

import json
import os
import re
import select
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
P01 = REPO / "participants" / "examples" / "P01.json"
THERMOCUE = [sys.executable, "-m", "experiments"]

PRESENTATION = {"instructions_key": True, "instructions_min_s": 2.0, "text_min_s": 1.0,
                "feedback_s": 1.5}
CONTACT_S, REWARM_S = 2.0, 3.0

PROTOCOL = """
[protocol]
name = "screens"
title = "One trial per block of roughness_recognition, for the screenshots"

[environment]
room_temperature_C = 20.0
skin_temperature_min_C = 35.5
skin_temperature_max_C = 36.0

[material]
name = "stainless_steel"
thickness_mm = 3.0

[[samples]]
id = 1
label = "1#"
roughness_um = 1.6

[[samples]]
id = 2
label = "2#"
roughness_um = 12.5

[[samples]]
id = 3
label = "3#"
roughness_um = 50.0

[[samples]]
id = 4
label = "4#"
roughness_um = 100.0

[contact]
force_threshold_N = 2.0
max_contact_s = {contact_s}
record_s = {contact_s}
trial_timeout_s = 30.0
rewarm_s = {rewarm_s}

[display]
min_C = 15.0
max_C = 42.0
max_rate_C_per_s = 10.0
neutral_C = 32.0

[grouping]
threshold_um = 800.0
margin_um = 50.0

[simulation]
skin_thickness = "group"
group_skin_thickness_um = {{ A = 650.0, B = 1000.0 }}
skin_temperature_C = 35.5
material_temperature_C = 20.0
duration_s = {contact_s}
rate_Hz = 100.0
resolution_C = 0.01
method = "exact"

[presentation]
answer_mode = "{mode}"
instructions_key = {instructions_key}
instructions_min_s = {instructions_min_s}
text_min_s = {text_min_s}
feedback_s = {feedback_s}

[schedule]
block_order = "fixed"

[[blocks]]
name = "familiarise"
mode = "real"
repetitions = 1
samples = [1]
order = "fixed"
scored = false
feedback = true
response = false
instructions = "Each sample is named before you touch it: remember how it feels."

[[blocks]]
name = "practice"
mode = "simulated"
repetitions = 1
samples = [2]
order = "fixed"
scored = false
feedback = true
instructions = "Practice: after each answer you are told whether it was right."

[[blocks]]
name = "real"
mode = "real"
repetitions = 1
samples = [3]
order = "random"
instructions = "Touch the sample when you hear the cue and say which one it is (1-4)."

[[blocks]]
name = "simulated"
mode = "simulated"
repetitions = 1
samples = [4]
order = "random"
instructions = "Put your finger on the display when you hear the cue and say which sample it feels like (1-4)."
"""

#: The participant's states in the order a session shows them: (key, state, what, minimum).
PARTICIPANT_STATES = [
    ("welcome", "welcome", "while the window and the display start", "text_min_s"),
    ("instructions", "instructions", "the block's instructions", "instructions_min_s"),
    ("instructions_key", "instructions", "then the same with \"Press space to continue\" "
     "until the space key", "instructions_min_s, then until a key"),
    ("please_wait", "please_wait", "the experimenter places the sample / the profile is uploaded",
     "text_min_s"),
    ("label", "label", "familiarisation: the sample is named before the touch", "text_min_s"),
    ("cue_label", "cue", "familiarisation: the cue with the name, for the whole touch",
     "text_min_s"),
    ("cue", "cue", "test trials: the cue (no name), until the contact has been recorded",
     "text_min_s"),
    ("question", "question", "after the contact, until the key 1-4", "text_min_s"),
    ("feedback", "feedback", "blocks with feedback = true, after the answer",
     "max(text_min_s, feedback_s)"),
    ("rewarm", "rewarm", "between trials, a countdown of the protocol's rewarm_s",
     "max(text_min_s, rewarm_s)"),
    ("finished", "finished", "the goodbye, then a blank frame and the window closes",
     "text_min_s"),
]

#: The experimenter's window: (key, pattern of its newest line, what).
EXPERIMENTER_LINES = [
    ("place_sample", r"place sample", "a real trial: which sample to place (space confirms)"),
    ("progress", r"^trial \d+ of \d+", "progress: trial, block, elapsed, time left"),
    ("read_instructions", r"^read to the participant", "spoken mode: instructions to read out"),
    ("say_label", r"^say to the participant: 'This is", "spoken mode: the name to say "
     "(familiarisation)"),
    ("question_asked", r"question asked", "spoken mode: the question's tone has sounded; key "
     "the spoken answer"),
    ("confirm_answer", r"^answer \d: space/return confirms", "spoken mode: confirm or undo"),
    ("undone", r"^undone", "spoken mode: the keyed answer was undone"),
    ("say_feedback", r"^say to the participant: '(Correct|Not correct)", "spoken mode: the "
     "feedback to say"),
    ("rewarm_told", r"rewarms the finger", "spoken mode: the rewarm"),
    ("say_goodbye", r"^say to the participant: 'Thank you", "spoken mode: the goodbye to say"),
]


# --------------------------------------------------------------------------- inside the session
def _install_recorder(record_path: str, events_path: str, shots_dir: str) -> None:
    """Watch every ``TextStim.draw`` and ``Window.flip`` (both still do their work)."""
    from psychopy import core, visual

    original_draw, original_flip = visual.TextStim.draw, visual.Window.flip
    shot_keys: set = set()
    drawn_since_flip: set = set()
    out = open(record_path, "a", encoding="utf-8")

    def write(rec):
        size = os.path.getsize(events_path) if os.path.exists(events_path) else 0
        out.write(json.dumps(dict(rec, events_bytes=size, t=core.getTime())) + "\n")
        out.flush()

    def shoot(window, key):
        shot = os.path.join(shots_dir, f"shot-{len(shot_keys) + 1:03d}.png")
        image = window.getMovieFrame(buffer="back")
        window.movieFrames.remove(image)
        image.save(shot)
        shot_keys.add(key)
        return shot

    def draw(self, win=None):
        result = original_draw(self, win)
        window = win if win is not None else self.win
        text = str(self.text)
        key = (window.title, re.sub(r"\d+ s$", "N s", text))   # one shot for a countdown
        shot = shoot(window, key) if key not in shot_keys else None
        drawn_since_flip.add(window.title)
        write({"kind": "draw", "text": text, "window": window.title, "shot": shot})
        return result

    def flip(self, *args, **kwargs):
        shot = None
        if self.title not in drawn_since_flip and ("blank", self.title) not in shot_keys:
            shot = shoot(self, ("blank", self.title))
        drawn_since_flip.discard(self.title)
        t = original_flip(self, *args, **kwargs)
        write({"kind": "flip", "window": self.title, "flip_s": t, "blank_shot": shot})
        return t

    visual.TextStim.draw = draw
    visual.Window.flip = flip


def _child(argv) -> int:
    record, events, shots, sep, *args = argv
    assert sep == "--"
    _install_recorder(record, events, shots)
    from experiments.cli import main
    return main(args)


# --------------------------------------------------------------------------- driving it
def _events(path: Path) -> list[dict]:
    out = []
    if path.exists():
        for line in path.read_text(encoding="utf-8").splitlines():
            try:
                out.append(json.loads(line))
            except ValueError:
                pass
    return out


def _key(env, key: str) -> None:
    subprocess.run(["xdotool", "search", "--sync", "--name", "^thermocue$", "windowfocus", "--sync",
                    "key", "--delay", "30", key], env=env, timeout=15, check=True,
                   capture_output=True)


def _run_session(cmd, env, events_path: Path, timeout_s: float = 300.0):
    """Run the session and play the participant and the experimenter with real keys: space for
    a placed sample or instructions, the trial's own sample as the answer; in the spoken mode
    the first answer is keyed wrong, undone with backspace, then keyed right and confirmed."""
    run = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    answered, undone = set(), False
    deadline = time.monotonic() + timeout_s
    try:
        while run.poll() is None and time.monotonic() < deadline:
            events = _events(events_path)
            waiting = [e for e in events if e["event"] == "awaiting_key" and e["seq"] not in answered]
            if not waiting:
                time.sleep(0.05)
                continue
            ev = waiting[0]
            started = [e for e in events if e["event"] == "trial_started" and e["seq"] < ev["seq"]]
            right = str(started[-1]["roughness_id"]) if started else "1"
            purpose = ev.get("purpose")
            if purpose == "spoken_answer":
                key = right if undone else ("1" if right != "1" else "2")
            elif purpose == "confirm_answer":
                key = "space" if ev["answer"] == right else "BackSpace"
                undone = undone or key == "BackSpace"
            else:
                key = "space" if "space" in ev["keys"] else right
            time.sleep(0.3)                     # someone reads the screen before the key
            for _ in range(2):                  # one retry if the key was missed
                _key(env, key)
                t0 = time.monotonic()
                while time.monotonic() - t0 < 4 and run.poll() is None and not any(
                        e["seq"] > ev["seq"] for e in _events(events_path)):
                    time.sleep(0.05)
                if run.poll() is not None or any(e["seq"] > ev["seq"] for e in _events(events_path)):
                    break
            answered.add(ev["seq"])
        _, err = run.communicate(timeout=30)
    finally:
        if run.poll() is None:
            run.kill()
            run.communicate()
    if run.returncode != 0:
        raise SystemExit(f"make_screens: the session failed (exit {run.returncode}):\n{err[-3000:]}")
    return err


def _start_xvfb():
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen(["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1280x1024x24",
                             "-nolisten", "tcp"], pass_fds=(write_fd,),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_fd)
    number = b""
    while not number.endswith(b"\n"):
        ready, _, _ = select.select([read_fd], [], [], 15)
        if not ready:
            proc.kill()
            raise SystemExit("make_screens: Xvfb gave no display number in 15 s")
        number += os.read(read_fd, 64)
    os.close(read_fd)
    return proc, f":{int(number.strip())}"


def _session(mode: str, work: Path, env: dict) -> dict:
    """One session in ``mode``; returns its events, draws, flips and stderr."""
    folder = work / mode
    shots = folder / "shots"
    shots.mkdir(parents=True)
    proto = folder / "screens.toml"
    proto.write_text(PROTOCOL.format(contact_s=CONTACT_S, rewarm_s=REWARM_S, mode=mode,
                                     **{k: str(v).lower() if isinstance(v, bool) else v
                                        for k, v in PRESENTATION.items()}), encoding="utf-8")
    link = folder / "thermal-pty"
    emulator = subprocess.Popen(THERMOCUE + ["emulator", "--link", str(link)], env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 30
        while not link.exists():
            if emulator.poll() is not None or time.monotonic() > deadline:
                raise SystemExit("make_screens: thermocue emulator did not start")
            time.sleep(0.05)
        data, record = folder / "data", folder / "drawn.jsonl"
        events_path = data / "P01" / "S01" / "events.jsonl"
        err = _run_session([sys.executable, str(Path(__file__).resolve()), "--child", str(record),
                            str(events_path), str(shots), "--", "run", str(proto),
                            "--participant", str(P01), "--display", str(link),
                            "--responder", "psychopy", "--data", str(data), "--seed", "5",
                            "--session", "S01", "--experimenter-screen", "0",
                            "--responder-option", "max_wait_s=60"], env, events_path)
    finally:
        emulator.terminate()
        emulator.wait(timeout=10)
    recs = [json.loads(line) for line in record.read_text(encoding="utf-8").splitlines()]
    return {"events": _events(events_path), "records": recs, "stderr": err}


# --------------------------------------------------------------------------- the table
def participant_times(events) -> list[dict]:
    """Each text the participant's window showed: state, text, first flip, seconds on screen
    (from its ``text_on`` flip to its ``text_off`` flip)."""
    out, on = [], None
    for e in events:
        if e["event"] == "text_on":
            on = e
        elif e["event"] == "text_off" and on is not None:
            out.append({"state": on["state"], "text": on["text"], "on_s": on["flip_s"],
                        "shown_s": e["flip_s"] - on["flip_s"]})
            on = None
    return out


def _key_of(state: str, text: str) -> str:
    if state == "cue" and text != "Touch now":
        return "cue_label"
    return state


def _minimum_s(rule: str) -> float:
    p = PRESENTATION
    return {"text_min_s": p["text_min_s"], "instructions_min_s": p["instructions_min_s"],
            "instructions_min_s, then until a key": p["instructions_min_s"],
            "max(text_min_s, feedback_s)": max(p["text_min_s"], p["feedback_s"]),
            "max(text_min_s, rewarm_s)": max(p["text_min_s"], REWARM_S)}[rule]


def _fmt(values) -> str:
    if not values:
        return "—"
    if len(values) == 1:
        return f"{values[0]:.3f}"
    return f"{min(values):.3f}–{max(values):.3f} (n = {len(values)})"


def collect(keyed: dict, spoken: dict):
    """The page's rows from both sessions (:func:`_session`'s dicts), writing nothing.

    Returns
    -------
    rows, exp_rows : list of tuple
        The participant's and the experimenter's table rows.
    copies : list of (str, str)
        Each screenshot to copy: its path, and its file name in the output folder.
    problems : list of str
        Why the page must not be written (a state with no screenshot, no measured time, or a
        time shorter than its minimum); empty when it may.
    """
    rows, exp_rows, copies, problems = [], [], [], []

    def _copy(shot, name: str) -> str:
        copies.append((shot, f"{name}.png"))
        return f"{name}.png"

    # --- the participant's window, keyed mode
    shown = participant_times(keyed["events"])
    draws = [r for r in keyed["records"] if r["kind"] == "draw"]
    part = [r for r in draws if r["window"] == "thermocue"]
    for key, state, what, rule in PARTICIPANT_STATES:
        times = [s["shown_s"] for s in shown
                 if s["state"] == state and _key_of(state, s["text"]) == key]
        if key == "instructions_key":
            times = []           # the same text_on as "instructions": one time for both
            match = [r for r in part if r["text"].endswith("Press space to continue")]
        else:
            texts = {s["text"] for s in shown if s["state"] == state
                     and _key_of(state, s["text"]) == key}
            match = [r for r in part if r["text"] in texts or (
                state == "rewarm" and r["text"].startswith("Rewarm"))]
        shot = next((r["shot"] for r in match if r["shot"]), None)
        if shot is None:
            problems.append(f"no screenshot of the participant's {key}")
            continue
        minimum = _minimum_s(rule)
        if key != "instructions_key" and not times:
            problems.append(f"{key}: no time on screen measured (no text_off after its "
                            f"text_on)")
        short = [t for t in times if t < minimum - 1e-4]
        if short:
            problems.append(f"{key} shown {min(short):.4f} s < its minimum {minimum} s")
        rows.append((key, _copy(shot, key), what, f"{rule} = {minimum:g} s"
                     if key != "instructions_key" else rule,
                     _fmt(times) if key != "instructions_key" else "(in the row above)"))

    # --- the participant's window, spoken mode: blank for the whole session
    flips = [r for r in spoken["records"] if r["kind"] == "flip" and r["window"] == "thermocue"]
    blank = next((r["blank_shot"] for r in flips if r["blank_shot"]), None)
    spoken_texts = [r for r in spoken["records"] if r["kind"] == "draw"
                    and r["window"] == "thermocue"]
    if blank is None or spoken_texts or any(e["event"] == "text_on" for e in spoken["events"]):
        problems.append("the spoken mode's participant window was not blank")
    else:
        span = flips[-1]["flip_s"] - flips[0]["flip_s"]
        rows.append(("spoken_blank", _copy(blank, "spoken_blank"),
                     "spoken mode: the participant's window, blank from the first frame to "
                     "the last (no text is drawn)", "—", f"{span:.3f} (whole session)"))

    # --- the experimenter's window (both sessions)
    for key, pattern, what in EXPERIMENTER_LINES:
        for run in (keyed, spoken):
            ed = [r for r in run["records"] if r["kind"] == "draw"
                  and r["window"] == "thermocue experimenter"]
            hit = next((i for i, r in enumerate(ed) if r["shot"] and
                        re.search(pattern, r["text"].splitlines()[-1])), None)
            if hit is None:
                continue
            later = [r for r in ed[hit + 1:] if r["text"] != ed[hit]["text"]]
            until = later[0]["t"] if later else None
            up = "until the window closed" if until is None else f"{until - ed[hit]['t']:.3f}"
            exp_rows.append((key, _copy(ed[hit]["shot"], f"experimenter_{key}"), what, up))
            break
        else:
            problems.append(f"no experimenter's line matching {pattern!r}")
    return rows, exp_rows, copies, problems


def build(out: Path, env: dict, keep: Path | None = None) -> str:
    """Run both sessions, write the PNGs and README.md into ``out``; return the README text.

    Nothing is written into ``out`` unless every check passes (:func:`collect`): a failed run
    leaves the previous screenshots and page as they were.
    """
    with tempfile.TemporaryDirectory(prefix="thermocue-screens-") as tmp:
        work = Path(tmp) if keep is None else keep
        work.mkdir(parents=True, exist_ok=True)
        home = work / "home"
        home.mkdir()
        (home / ".asoundrc").write_text("pcm.!default { type null }\n")
        env = {**env, "HOME": str(home),
               "PYTHONPATH": str(REPO) + os.pathsep + env.get("PYTHONPATH", "")}
        keyed = _session("keyed", work, env)
        spoken = _session("spoken", work, env)
        load = os.getloadavg()
        rows, exp_rows, copies, problems = collect(keyed, spoken)
        if problems:
            raise SystemExit("make_screens: " + "; ".join(problems))
        out.mkdir(parents=True, exist_ok=True)
        for shot, name in copies:
            tmp_png = out / f".{name}.tmp"
            shutil.copyfile(shot, tmp_png)
            tmp_png.replace(out / name)

    lines = [
        "# The windows, state by state (screenshots on the real clock)",
        "",
        "Written by `python docs/screens/make_screens.py` (this folder's script; it says how): two",
        "short sessions (`answer_mode = \"keyed\"` and `\"spoken\"`, `--experimenter-screen 0`) against",
        "`thermocue emulator` on a pty, on the real clock, under Xvfb with real X key presses. The",
        "protocol's `[presentation]` is the default: "
        + ", ".join(f"`{k} = {str(v).lower() if isinstance(v, bool) else v}`"
                    for k, v in PRESENTATION.items())
        + f"; contacts of {CONTACT_S:g} s, rewarm {REWARM_S:g} s.",
        "",
        "**Measured on screen** is from the text's first frame to the frame that replaced it",
        "(PsychoPy's flip times logged as `text_on`/`text_off` in `events.jsonl`), in seconds;",
        "a state shown several times gives its range. The script fails rather than writes this page",
        "if any text was shorter than its minimum. Minimums are lower bounds: how much longer a text",
        "stays depends on the participant, the experimenter and the display (the cue stays up until",
        "the contact has been recorded, the question until the key; the keys here come 0.3 s after",
        "the window asks, so the question and the instructions stay about their minimum). Against the",
        "emulator the stand-in hand presses as soon as the display is armed, before the cue is up,",
        "so the cue's time here is shorter than the contact; with a person it includes the reach.",
        f"Load average while it ran: {load[0]:.2f}, {load[1]:.2f}, {load[2]:.2f}.",
        "",
        "## The participant's window",
        "",
        "| state | screenshot | when | minimum (protocol) | measured on screen, s |",
        "|---|---|---|---|---|",
    ]
    for key, png, what, minimum, measured in rows:
        lines.append(f"| `{key}` | ![{key}]({png}) | {what} | {minimum} | {measured} |")
    lines += [
        "",
        "## The experimenter's window (`--experimenter-screen N`)",
        "",
        "The newest 14 lines (each also printed on the terminal); each screenshot is the window when",
        "the line named came in (its last line). The experimenter's lines have no minimum time; the",
        "time given is from that line's draw to the next line's (it then stays in view, higher up).",
        "",
        "| line | screenshot | when | measured on screen, s |",
        "|---|---|---|---|",
    ]
    for key, png, what, up in exp_rows:
        lines.append(f"| `{key}` | ![{key}]({png}) | {what} | {up} |")
    text = "\n".join(lines) + "\n"
    tmp_readme = out / ".README.md.tmp"
    tmp_readme.write_text(text, encoding="utf-8")
    tmp_readme.replace(out / "README.md")
    return text


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        return _child(argv[1:])
    keep = None
    if "--keep" in argv:
        i = argv.index("--keep")
        keep = Path(argv[i + 1]).resolve()
        argv = argv[:i] + argv[i + 2:]
    out = Path(argv[0]) if argv else HERE
    if shutil.which("xdotool") is None:
        print("make_screens: xdotool is not installed (scripts/setup installs it)", file=sys.stderr)
        return 2
    env, xvfb = dict(os.environ), None
    if not env.get("DISPLAY"):
        xvfb, env["DISPLAY"] = _start_xvfb()
    try:
        print(build(out, env, keep))
    finally:
        if xvfb is not None:
            xvfb.terminate()
            xvfb.wait(timeout=10)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Run ``thermocue`` with every text drawn by PsychoPy recorded (a test helper, run as a script).

    python _draw_recorder.py RECORD.jsonl EVENTS.jsonl SHOTS_DIR -- run PROTOCOL ...

Wraps ``psychopy.visual.TextStim.draw`` (the real method still draws: this only watches it) so
that each call appends ``{"text", "window", "events_bytes", "shot"}`` to RECORD.jsonl:
``events_bytes`` is the size of the session's EVENTS.jsonl at that moment (the engine fsyncs
every event before going on, so it places each draw exactly between two logged events), and
``shot`` the PNG of the window's back buffer just after the first draw of each distinct text
(``win.getMovieFrame(buffer='back')``, FACTS: the front buffer reads back black under Xvfb).
"""
from __future__ import annotations

import json
import os
import re
import sys


def install(record_path: str, events_path: str, shots_dir: str) -> None:
    from psychopy import visual

    original = visual.TextStim.draw
    shots: dict[str, str] = {}
    out = open(record_path, "a", encoding="utf-8")

    def draw(self, win=None):
        result = original(self, win)
        window = win if win is not None else self.win
        text = str(self.text)
        key = re.sub(r"\d+ s$", "N s", text)          # one shot for a whole countdown
        shot = None
        if key not in shots:
            shot = os.path.join(shots_dir, f"shot-{len(shots) + 1:03d}.png")
            image = window.getMovieFrame(buffer="back")
            window.movieFrames.remove(image)
            image.save(shot)
            shots[key] = shot
        size = os.path.getsize(events_path) if os.path.exists(events_path) else 0
        out.write(json.dumps({"text": text, "window": window.title, "events_bytes": size,
                              "shot": shot}) + "\n")
        out.flush()
        return result

    visual.TextStim.draw = draw


if __name__ == "__main__":
    record, events, shots, sep, *args = sys.argv[1:]
    assert sep == "--", "usage: _draw_recorder.py RECORD EVENTS SHOTS -- thermocue arguments"
    install(record, events, shots)
    from experiments.cli import main
    sys.exit(main(args))

"""The repository stands alone: no file cites a design document or an issue tracker outside it.

The design is ``docs/design.md``; a reader of the repository cannot see the tracker the work was
planned in, so a comment, docstring or document says what it means instead of "issue N".
Every file of the repository is scanned (tracked or not, but not what ``.gitignore`` ignores).
"""
from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Built from parts so that this file does not match itself.
OUTSIDE_DESIGN = re.compile(re.escape("DESIGN" + ".md"))
ISSUE = re.compile(r"\b[Ii]ssues?\s+#?\d+|\b[Ii]ssue\s*#\d+|\b[Ii]ssues?\s+\d+\s*/\s*\d+")
SKIPPED_DIRS = {".git", ".venv", "__pycache__", ".pytest_cache", ".hypothesis"}


def _files() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                             cwd=ROOT, capture_output=True, check=True).stdout
        names = [n for n in out.decode("utf-8", "surrogateescape").split("\0") if n]
        return [ROOT / n for n in names if (ROOT / n).is_file()]
    except (OSError, subprocess.CalledProcessError):      # not a git checkout: walk the tree
        found = []
        for folder, dirs, files in os.walk(ROOT):
            dirs[:] = [d for d in dirs if d not in SKIPPED_DIRS and not d.endswith(".egg-info")]
            found += [Path(folder) / f for f in files]
        return found


def _text(path: Path) -> str | None:
    data = path.read_bytes()
    if b"\0" in data[:8192]:                                  # binary (images, archives)
        return None
    return data.decode("utf-8", errors="replace")


def _citations(pattern) -> list[str]:
    hits = []
    for path in _files():
        if set(path.relative_to(ROOT).parts) & SKIPPED_DIRS:
            continue
        text = _text(path)
        if text is None:
            continue
        for number, line in enumerate(text.splitlines(), 1):
            if pattern.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:100]}")
    return hits


def test_the_scan_sees_the_repository():
    files = {p.relative_to(ROOT).as_posix() for p in _files()}
    assert {"docs/design.md", "CONTRIBUTING.md", "stimuli/laplace.py",
            "tests/test_self_contained_docs.py"} <= files


def test_the_patterns_match_what_they_must():
    assert OUTSIDE_DESIGN.search("see " + "DESIGN" + ".md, Contracts")
    assert not OUTSIDE_DESIGN.search("see docs/design.md, Contracts")
    word = "iss" + "ue"                                      # so that this file does not match
    for cited in (f"({word} 12)", f"{word} #4", f"{word.title()} 12 changed", f"{word}s 10/16",
                  f"{word}s 3 and", f"{word} 16: claims"):
        assert ISSUE.search(cited), cited
    for fine in ("an issue with the clock", "issues of the printed equations", "tissue 2 layers"):
        assert not ISSUE.search(fine), fine


def test_no_file_cites_a_design_document_outside_the_repository():
    assert _citations(OUTSIDE_DESIGN) == []


def test_no_file_cites_an_issue_tracker():
    assert _citations(ISSUE) == []

"""Shared by the tests under tests/experiments/: the helper modules of this folder
(``_session_helpers``, ``_calibration_helpers``, ...) are importable from its sub-folders
(calibration/, cli/, responders/, simulation/, ...), which mirror the packages of experiments."""
from __future__ import annotations

import sys
from pathlib import Path

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

"""``thermocue check``: a display's bring-up and qualification, with no finger on it.

Each module holds one group of checks; every check is a function ``check_x(bench) ->
CheckResult`` that runs on any backend and **fails with the reason** where it should run and
cannot (never skipped); a check the backend's declared capabilities rule out
(:mod:`.applicability`: ``Capabilities.lacks``) is listed as not applicable, naming the missing
capability, and does not fail the run. :func:`run_checks` runs them in order and :func:`write_report` writes
``check.md`` with the plots. The conformance suite calls the same functions
(``tests/conformance/test_qualification.py``).
"""
from __future__ import annotations

from .result import CheckResult
from .runner import CHECKS, run_checks
from .report import write_report

__all__ = ["CheckResult", "CHECKS", "run_checks", "write_report"]

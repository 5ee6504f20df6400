"""The outcome of one check: passed or failed against the limit it states, and what to look at."""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class CheckResult:
    """One check's outcome.

    Parameters
    ----------
    name : str
        The check's short name (``sensors``, ``step``, ...).
    title : str
        One line: what was checked.
    passed : bool
    limit : str
        The limit the check holds the device to, with units.
    measured : str
        What was measured, with units.
    reason : str
        Why it failed (or why it could not run on this device: also a failure).
    look_at : str
        One line: what to look at when it failed (wiring, calibration constant, fan, ...).
    seconds : float, s
        Wall time the check took.
    plots : list of str
        File names of the check's plots, relative to the report's folder.
    board_only : str
        What of this check only a physical board can settle ("" when the check settles it here).
    not_applicable : str
        The capability the backend declares it lacks (``Capabilities.lacks``, or
        ``force_sensing``/``playback``) that this check needs: the check was not run on this
        backend and does not fail the run ("" for a check that ran, or could not and failed).
    """

    name: str
    title: str
    passed: bool
    limit: str
    measured: str = ""
    reason: str = ""
    look_at: str = ""
    seconds: float = 0.0
    plots: list = field(default_factory=list)
    board_only: str = ""
    not_applicable: str = ""

    @property
    def outcome(self) -> str:
        """``pass``, ``FAIL`` or ``not applicable``."""
        return "not applicable" if self.not_applicable else ("pass" if self.passed else "FAIL")

    @property
    def failed(self) -> bool:
        """Whether the check fails the run (a not-applicable check does not)."""
        return not self.passed and not self.not_applicable


def not_offered(name: str, title: str, limit: str, capability: str, why: str,
                board_only: str = "") -> CheckResult:
    """A check the backend's declared capabilities do not offer: listed, not run, not failing."""
    return CheckResult(name, title, False, limit, "not run",
                       f"not applicable to this backend: it lacks {capability} ({why})",
                       board_only=board_only, not_applicable=capability)


def cannot_run(name: str, title: str, limit: str, why: str, look_at: str = "",
               board_only: str = "") -> CheckResult:
    """A check this device should run but cannot: a failure, with the reason."""
    return CheckResult(name, title, False, limit, "not measured", f"cannot run here: {why}",
                       look_at or "a device (or backend) that offers it", board_only=board_only)

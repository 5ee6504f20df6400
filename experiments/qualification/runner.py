"""The checks in their order, run one after the other with progress and time remaining."""
from __future__ import annotations

import time

from .applicability import TITLES, missing_capability
from .clock import check_clock
from .result import CheckResult, not_offered
from .safety_checks import check_limits, check_overtemp, check_watchdog
from .sensors import check_force, check_sensors
from .thermal import check_neutral, check_step, check_tracking

__all__ = ["CHECKS", "run_checks"]

#: (check, rough wall time on a real clock, s) in the order they run: the sensors first (a
#: broken sensor makes every later figure meaningless), the safety checks before the long ones.
CHECKS = (
    (check_sensors, 2), (check_neutral, 5), (check_force, 3), (check_limits, 5),
    (check_overtemp, 8), (check_watchdog, 3), (check_step, 12), (check_clock, 3),
    (check_tracking, 45),
)


def run_checks(bench, checks=CHECKS, progress=None) -> list[CheckResult]:
    """Run ``checks`` on ``bench``; a check that raises fails with the error as its reason; a
    check the backend's declared capabilities do not offer is listed as not applicable
    (:mod:`.applicability`), not run.

    ``progress(text)`` gets one line per check with the time remaining (estimated).
    """
    results = []
    left = sum(s for _, s in checks)
    caps = bench.display.capabilities
    for i, (fn, est) in enumerate(checks, start=1):
        name = fn.__name__.removeprefix("check_")
        missing = missing_capability(name, caps)
        if missing is not None:
            results.append(not_offered(name, TITLES.get(name, name), "see docs/check.md", *missing))
            left = max(0.0, left - est)
            if progress:
                progress(f"[{i}/{len(checks)}] {name}: not applicable to this backend (it lacks "
                         f"{missing[0]}: {missing[1]})")
            continue
        if progress:
            progress(f"[{i}/{len(checks)}] {name}: {fn.__doc__.splitlines()[0]} "
                     f"(about {left:.0f} s left)")
        t0 = time.monotonic()
        try:
            res = fn(bench)
        except Exception as exc:                 # a display error is this check's failure
            res = CheckResult(name, (fn.__doc__ or name).splitlines()[0], False, "see the check",
                              "not measured", f"{type(exc).__name__}: {exc}",
                              "the link and the device's state (thermocue clear-fault if latched)")
            _recover(bench)
        res.seconds = time.monotonic() - t0
        results.append(res)
        left = max(0.0, left - est)
        if progress:
            progress(f"      {res.outcome} in {res.seconds:.1f} s"
                     + ("" if res.passed else f": {res.reason}"))
    return results


def _recover(bench) -> None:
    """After a check that raised: back to neutral if the device lets us (best effort)."""
    d = bench.display
    try:
        d.abort()
        d.set_neutral(bench.neutral_C)
    except Exception:
        pass

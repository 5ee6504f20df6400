"""Open a display by URL, run every check, write the report: what ``thermocue check`` does."""
from __future__ import annotations

from pathlib import Path

from .bench import Bench
from .report import write_report
from .result import CheckResult
from .runner import CHECKS, run_checks

__all__ = ["qualify", "device_summary"]

_LATCHED_LOOK_AT = {
    "SENSOR_FAILURE": "the contact thermistor's wiring and ADC channel (it reads out of range)",
    "SENSOR_STUCK": "the contact thermistor's wiring and ADC channel (its reading does not move)",
    "OVER_TEMPERATURE": "the pad, the heat sink's fan and the Peltier driver",
}


def device_summary(d) -> dict:
    """Device id, firmware, capabilities and limits for the report's head."""
    info = getattr(d, "info", None)
    out = {}
    if info is not None:
        out["device id"] = info.device_id
        out["firmware"] = info.firmware
        out["capabilities"] = ", ".join(info.capabilities)
        for key in ("image_id",):
            if getattr(info, key, None):
                out["firmware image id"] = getattr(info, key)
    c = d.capabilities
    out["safe range"] = f"{c.safe_range_C[0]:g}–{c.safe_range_C[1]:g} °C"
    out["max rate"] = f"{c.max_rate_C_per_s:g} °C/s"
    return out


def _unopened(exc: Exception, checks) -> list[CheckResult]:
    """Every check fails when the display cannot be opened; a latched sensor fault names the
    sensors check's look-at."""
    code = getattr(exc, "code", None)
    out = []
    for fn, _ in checks:
        name = fn.__name__.removeprefix("check_")
        title = (fn.__doc__ or name).splitlines()[0]
        look = "the port, the cable and the device's power"
        if code in _LATCHED_LOOK_AT:
            look = _LATCHED_LOOK_AT[code] if name == "sensors" else \
                "the sensors check first: the device is latched in FAULT"
        out.append(CheckResult(name, title, False, "see docs/check.md", "not measured",
                               f"the display could not be opened: {exc}", look))
    return out


def qualify(url, out: Path, prompt=None, protocol=None, profile_s: float = 3.0,
            progress=None, checks=CHECKS, limits=None):
    """Open ``url`` (the registry), run ``checks``, write ``out/check.md``.

    ``url`` is a display URL, or one parsed already (:class:`~experiments.display.url.DisplayURL`:
    ``thermocue check`` parses it once and passes it on); the report shows its text.

    Returns
    -------
    (results, report_path)
    """
    from experiments.display import open_display
    from experiments.display.registry import parse_display_url
    from experiments.errors import DisplayError
    url = parse_display_url(url)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    tracking = protocol.simulation.max_tracking_error_C if protocol is not None else 1.0
    try:
        d = open_display(url, limits)
    except DisplayError as exc:
        results = _unopened(exc, checks)
        return results, write_report(out, url.text, {}, results, str(exc))
    try:
        bench = Bench(d, url.text, out, prompt=prompt, tracking_limit_C=tracking, protocol=protocol,
                      profile_s=profile_s)
        results = run_checks(bench, checks, progress)
        return results, write_report(out, url.text, device_summary(d), results)
    finally:
        d.close()

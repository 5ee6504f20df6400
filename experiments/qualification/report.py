"""``check.md``: the device, then one section per check with its limit, what was measured,
pass or fail, what to look at, and its plots."""
from __future__ import annotations

from pathlib import Path

__all__ = ["write_report", "render_report"]


def _cell(text: str) -> str:
    """A table cell: its own pipes (|ΔT|) escaped."""
    return str(text).replace("|", "\\|")


def render_report(url: str, device: dict, results, opened_error: str | None = None) -> str:
    passed = sum(r.passed for r in results)
    na = [r for r in results if r.not_applicable]
    ran = len(results) - len(na)
    lines = ["# thermocue check", "", f"- display: `{url}`"]
    for k, v in device.items():
        lines.append(f"- {k}: {v}")
    verdict = "PASS" if ran and not any(r.failed for r in results) else "FAIL"
    lines.append(f"- result: **{verdict}** ({passed} of {ran} checks passed"
                 + (f"; {len(na)} not applicable to this backend, not run)" if na else ")"))
    lines.append("")
    if opened_error:
        lines += [f"The display could not be opened: {opened_error}", ""]
    lines += ["| check | result | time (s) | limit | measured |", "|---|---|---|---|---|"]
    for r in results:
        shown = {"pass": "pass", "FAIL": "**FAIL**"}.get(r.outcome, f"not applicable ({r.not_applicable})")
        lines.append(f"| {r.name} | {shown} | {r.seconds:.1f} | {_cell(r.limit)} | {_cell(r.measured)} |")
    lines.append("")
    fails = [r for r in results if r.failed]
    if fails:
        lines += ["## What to look at", ""]
        lines += [f"- **{r.name}**: {r.reason}. Look at: {r.look_at or 'the device'}." for r in fails]
        lines.append("")
    if na:
        lines += ["## Not run on this backend", "",
                  "The backend declares it lacks what these checks need (its capabilities), so "
                  "they were not run and do not fail the check; a physical thermocue display runs "
                  "them all.", ""]
        lines += [f"- **{r.name}** ({r.title}): {r.reason}." for r in na]
        lines.append("")
    lines += ["## Checks", ""]
    for r in results:
        lines += [f"### {r.name}: {r.title}", "",
                  f"- result: {r.outcome} ({r.seconds:.1f} s)",
                  f"- limit: {r.limit}", f"- measured: {r.measured}"]
        if r.reason:
            lines.append(f"- {'note' if r.passed else 'reason'}: {r.reason}")
        if r.board_only:
            lines.append(f"- only a physical board settles: {r.board_only}")
        lines += [""] + [f"![{p}]({p})" for p in r.plots] + ([""] if r.plots else [])
    return "\n".join(lines) + "\n"


def write_report(out: Path, url: str, device: dict, results, opened_error=None) -> Path:
    """Write ``out/check.md`` atomically (temp + rename); return its path."""
    out = Path(out)
    text = render_report(url, device, results, opened_error)
    path = out / "check.md"
    tmp = out / ".check.md.tmp"
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)
    return path

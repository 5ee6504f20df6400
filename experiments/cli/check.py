"""`thermocue check URL`: a display's bring-up and qualification, with no finger on it.

Runs every check of :mod:`experiments.qualification` that the display backend's declared
capabilities allow (a check they rule out is listed as not applicable, naming the capability the
backend lacks, and not run; a check that should run but cannot fails with the reason), writes
``check.md`` and the plots to ``--out``, and exits 0 when every check that ran passed, 1 when any
failed (or none ran), 2 on bad input.
"""
from __future__ import annotations

import sys


def register(sub) -> None:
    p = sub.add_parser(
        "check", help="qualify a display: sensors, neutral, steps, tracking, safety, clock",
        description="Bring a display up and prove it, with no finger on the pad: each sensor, "
                    "the neutral hold, the step response, tracking of the paper's profiles, the "
                    "rate limit and safe range, the over-temperature trip (lowered for the test), "
                    "the watchdog, the force sensors (the operator places a known weight) and "
                    "the clock mapping. docs/check.md lists each check and its limit.")
    p.add_argument("url", metavar="URL", help="the display: emulator://, qemu-firmware://, "
                                              "tcs2://PORT, a serial device or pty path")
    p.add_argument("--out", default="check", metavar="DIR",
                   help="folder for check.md and the plots (default ./check)")
    p.add_argument("--no-prompt", action="store_true",
                   help="never ask the operator (the known-weight test is then not run and "
                        "counts as failed, with the reason in the report)")
    p.add_argument("--protocol", default=None, metavar="NAME",
                   help="protocol whose profiles and tracking tolerance are used (default "
                        "roughness_recognition; roughness_recognition_tcs2 on tcs2://)")
    p.add_argument("--profile-s", type=float, default=3.0, metavar="S",
                   help="seconds of each paper profile played (default 3: their steep start)")
    p.set_defaults(func=_run)


def _prompt(text: str) -> str:
    try:
        return input(text)
    except EOFError:
        return ""


def _run(ns) -> int:
    from experiments.cli.paths import check_writable_dir
    from experiments.display.registry import parse_display_url
    from experiments.errors import UserInputError
    from experiments.protocol import load_protocol
    from experiments.qualification.qualify import qualify

    url = parse_display_url(ns.url)                   # once; a bad URL: one line, exit 2
    if not 0.5 <= ns.profile_s <= 30:
        raise UserInputError(f"--profile-s: expected 0.5–30 s, got {ns.profile_s:g}")
    name = ns.protocol or ("roughness_recognition_tcs2" if url.scheme == "tcs2"
                           else "roughness_recognition")
    protocol = load_protocol(name)
    out = check_writable_dir(ns.out, "--out")
    prompt = None
    if not ns.no_prompt:
        if not sys.stdin.isatty():
            raise UserInputError("--no-prompt: expected it when stdin is not a terminal (the "
                                 "known-weight test asks the operator)")
        prompt = _prompt
    results, path = qualify(url, out, prompt=prompt, protocol=protocol,
                            profile_s=ns.profile_s, progress=lambda s: print(s, file=sys.stderr),
                            limits=protocol.display.safety_limits())
    passed = sum(r.passed for r in results)
    na = [r for r in results if r.not_applicable]
    ran = len(results) - len(na)
    print(f"{path}: {passed} of {ran} checks passed"
          + (f"; {len(na)} not applicable to this backend (not run: "
             f"{', '.join(f'{r.name}, lacks {r.not_applicable}' for r in na)})" if na else ""))
    for r in results:
        if r.failed:
            print(f"  FAIL {r.name}: {r.reason} -- look at {r.look_at}")
    return 0 if ran and not any(r.failed for r in results) else 1

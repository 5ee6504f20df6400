"""`thermocue displays`: the registered display backends, what each can do, and whether it runs here.

Thin over :mod:`experiments.display.registry`: one row per backend (URL scheme, availability,
contact detection, force sensing, telemetry rate, longest profile, safe range, rate limit, modes),
or ``--json`` for a machine-readable list.
"""
from __future__ import annotations

import json
import sys


def register(sub) -> None:
    p = sub.add_parser(
        "displays",
        help="list the display backends (URL schemes), what each supports and whether it runs here",
        description="List the registered display backends: the URL to give --display, whether the "
                    "backend can be opened on this machine, and what it supports (contact "
                    "detection, force, telemetry rate, profile length, safe range, modes).")
    p.add_argument("--json", action="store_true", help="print the list as JSON")
    p.set_defaults(func=_run)


def describe() -> list[dict]:
    """One dict per registered backend (scheme, URL grammar, example URLs, description,
    availability, capabilities) and one per refused plugin (``broken``: why); a backend whose
    own statements fail is listed as broken, and the others still are."""
    from experiments.display.registry import backends, broken_plugins
    rows = []
    for cls in backends():
        row = dict(scheme=cls.scheme, url=cls.url_grammar, description=cls.description,
                   examples=[url for url, _ in getattr(cls, "example_urls", ()) or ()])
        try:
            ok, reason = cls.availability()
            row.update(available=bool(ok), unavailable_reason=reason or None,
                       capabilities=cls.declared_capabilities().to_dict(), broken=None)
        except Exception as exc:    # a plugin that states too little: listed, not fatal
            row.update(available=False, unavailable_reason=None, capabilities=None,
                       broken=f"{cls.__module__}.{cls.__qualname__}: {type(exc).__name__}: "
                              f"{' '.join(str(exc).split())[:300]}")
        rows.append(row)
    for name, (module, why) in sorted(broken_plugins().items()):
        rows.append(dict(scheme=None, plugin=name, module=module, url=None, description=None,
                         examples=[], available=False, unavailable_reason=None,
                         capabilities=None, broken=why))
    return rows


def _run(ns) -> int:
    rows = describe()
    if ns.json:
        json.dump(rows, sys.stdout, indent=2, ensure_ascii=False)
        print()
        return 0
    for r in rows:
        if r["scheme"] is None:
            print(f"plugin {r['plugin']} ({r['module']})  (broken: {r['broken']})")
            continue
        if r["broken"]:
            print(f"{r['scheme']}  (broken: {r['broken']})")
            continue
        c = r["capabilities"]
        state = "available" if r["available"] else f"not available here: {r['unavailable_reason']}"
        lo, hi = c["safe_range_C"]
        print(f"{r['scheme']}  ({state})")
        print(f"    URL: {r['url']}")
        if r["examples"]:
            print(f"    e.g. {', '.join(r['examples'])}")
        print(f"    {r['description']}")
        print(f"    contact detection: {c['contact_detection']}; force sensing: "
              f"{'yes' if c['force_sensing'] else 'no'}; telemetry: {c['telemetry_hz']:g} Hz")
        print(f"    profile: up to {c['max_profile_points']} points, step >= "
              f"{c['min_profile_step_s'] * 1e3:g} ms; safe range {lo:g}-{hi:g} °C; rate <= "
              f"{c['max_rate_C_per_s']:g} °C/s")
        print(f"    modes: {', '.join(c['modes'])}; scripted bench: "
              f"{'yes' if c['scripted_bench'] else 'no'}")
        if c["notes"]:
            print(f"    {c['notes']}")
    return 0

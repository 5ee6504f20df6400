"""``thermocue bench {model,display} [--out DIR]``: speed-against-error benchmarks.

``model`` times every thermal-model method on a 20 s profile at 1 kHz against mpmath references
(:mod:`experiments.bench.model`); ``display`` runs the display loop benchmark
(:mod:`experiments.bench.display`, ``run_display_benchmark(out_dir) -> dict``). Both print their
table and write ``DIR/bench.json`` (unit in every field name) and a PNG.
"""
from __future__ import annotations

from pathlib import Path

__all__ = ["register"]


def register(sub) -> None:
    p = sub.add_parser("bench", help="speed-against-error benchmarks (model, display)",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("target", choices=("model", "display"), help="what to benchmark")
    p.add_argument("--out", metavar="DIR", default=None,
                   help="output folder (default: ./bench-<target>)")
    p.add_argument("--quick", action="store_true",
                   help="model only: fewer repeats, grids and reference points (for smoke tests)")
    p.set_defaults(func=_run)


def _run(ns) -> int:
    from experiments.errors import UserInputError

    out = Path(ns.out if ns.out is not None else f"bench-{ns.target}")
    if out.exists() and not out.is_dir():
        raise UserInputError(f"thermocue bench: --out: expected a folder, got {str(out)!r} (a file)")
    if ns.target == "model":
        from experiments.bench.model import run_model_benchmark
        run_model_benchmark(out, quick=ns.quick)
        return 0
    if ns.quick:
        raise UserInputError("thermocue bench: --quick: expected only with 'model', got 'display'")
    try:
        from experiments.bench.display import run_display_benchmark
    except ImportError as exc:
        print(f"thermocue bench display: not available ({exc})")
        return 1
    run_display_benchmark(out)
    return 0

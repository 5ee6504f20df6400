"""``thermocue psyexp compile EXPERIMENT.psyexp [-o SCRIPT.py]``: Builder's compile, plugins on.

PsychoPy's command-line compiler (``python -m psychopy.scripts.psyexpCompile``) does not
activate plugins, so it leaves the Thermal cue component out (a script compiled that way stops
on its first line with this command as the fix: :mod:`experiments.psychopy_plugin.component.stripped`).
This command activates them as the Builder app does, then runs PsychoPy's own compiler
(``psyexpCompile.compileScript``), and checks that no Thermal cue component was left out.
"""
from __future__ import annotations

import sys
from pathlib import Path

__all__ = ["register"]


def register(sub) -> None:
    p = sub.add_parser("psyexp", help="Builder experiments: compile with the thermocue plugin active",
                       description=__doc__.split("\n\n")[0])
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    c = verbs.add_parser("compile", help="compile a .psyexp to a Python script (PsychoPy's "
                                         "compiler, plugins activated)")
    c.add_argument("psyexp", help="the Builder experiment (.psyexp)")
    c.add_argument("-o", "--outfile", default=None,
                   help="the script to write (default: beside the experiment, .py)")
    c.set_defaults(func=_compile)


def _compile(ns) -> int:
    import xml.etree.ElementTree as ET

    from experiments.errors import UserInputError
    src = Path(ns.psyexp)
    if not src.is_file():
        raise UserInputError(f"{src}: expected a Builder experiment file (.psyexp), got no such file")
    try:
        ET.parse(src)
    except ET.ParseError as exc:
        raise UserInputError(f"{src}: expected a Builder experiment (XML), got {exc}") from None
    out = Path(ns.outfile) if ns.outfile else src.with_suffix(".py")
    if not out.parent.is_dir():
        raise UserInputError(f"--outfile {out}: expected a file in an existing folder, got no "
                             f"folder {out.parent}")
    from experiments.psychopy_plugin.compile import compile_psyexp
    from experiments.psychopy_plugin.component.stripped import left_out_components
    tmp = out.with_name(f".{out.name}.compiling.py")
    try:
        compile_psyexp(src, tmp)
        left, _ = left_out_components(tmp, src)
        if left:
            print(f"thermocue psyexp compile: {src}: PsychoPy left out {', '.join(left)}: the "
                  "thermocue plugin is not active in this Python (is thermocue installed here, "
                  "with its entry points?)", file=sys.stderr)
            return 1
        tmp.replace(out)
    except OSError as exc:
        print(f"thermocue psyexp compile: {exc.filename or out}: {exc.strerror or exc}", file=sys.stderr)
        return 1
    finally:
        if tmp.exists():
            tmp.unlink()
    print(out)
    return 0


"""Compile a ``.psyexp`` to a Python script with PsychoPy's own compiler, plugins activated.

PsychoPy's command-line compiler (``python -m psychopy.scripts.psyexpCompile``) does not
activate plugins, so it writes ``# Unknown component ignored: thermal`` in place of a plugin's
component (PsychoPy's alert 7105); the Builder app activates them when it starts. This does what
the app does: ``plugins.activatePlugins()``, then ``psyexpCompile.compileScript``::

    python -m experiments.psychopy_plugin.compile EXPERIMENT.psyexp [-o SCRIPT.py]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

__all__ = ["compile_psyexp", "main"]


def compile_psyexp(psyexp, out=None) -> Path:
    """Write the Python script of ``psyexp`` (default: beside it, ``.py``); return its path."""
    from psychopy import plugins
    plugins.activatePlugins()
    from psychopy.scripts import psyexpCompile
    src = Path(psyexp)
    if not src.is_file():
        raise FileNotFoundError(f"{src}: no such experiment file")
    dst = Path(out) if out is not None else src.with_suffix(".py")
    psyexpCompile.compileScript(str(src), None, str(dst))
    return dst


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.psychopy_plugin.compile",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("psyexp")
    parser.add_argument("-o", "--outfile", default=None)
    ns = parser.parse_args(argv)
    try:
        print(compile_psyexp(ns.psyexp, ns.outfile))
    except FileNotFoundError as exc:
        print(f"compile: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())

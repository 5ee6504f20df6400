"""Stop a Builder script that PsychoPy compiled without this plugin, naming the fix.

PsychoPy's command-line compiler (``python -m psychopy.scripts.psyexpCompile``) does not
activate plugins: it replaces a Thermal cue component by ``# Unknown component ignored: NAME``
yet keeps ``NAME`` in its routine's component list, so the script would stop with a
``NameError`` in the middle of the first routine, after the window opened. Every compiled script
activates plugins on its first lines (``plugins.activatePlugins()``), which imports this plugin's
component module; that import calls :func:`check_main_script`, which reads the running script
(``__main__``) and the ``.psyexp`` beside it and, when a component of this plugin was left out,
exits with one line saying how to compile it (``thermocue psyexp compile``) before anything
opens. Any other script, or one without its ``.psyexp`` beside it, is left alone.
"""
from __future__ import annotations

import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

__all__ = ["check_main_script", "left_out_components", "COMPONENT_TAG"]

#: The XML tag of this plugin's component in a ``.psyexp``.
COMPONENT_TAG = "ThermalCueComponent"
_IGNORED = re.compile(r"^[ \t]*# Unknown component ignored: (\w+)[ \t]*$", re.M)
_EXPNAME = re.compile(r"^expName = '([^']+)'", re.M)


def _psyexp_beside(script: Path, text: str) -> list[Path]:
    found = [script.with_suffix(".psyexp")]
    m = _EXPNAME.search(text)
    if m:
        found.append(script.parent / f"{m.group(1)}.psyexp")
    return [p for p in dict.fromkeys(found) if p.is_file()]


def left_out_components(script, psyexp=None) -> tuple[list[str], Path | None]:
    """The Thermal cue components PsychoPy left out of ``script``, and the ``.psyexp`` naming them.

    Parameters
    ----------
    script : path-like
        A Python script written by PsychoPy's compiler.
    psyexp : path-like, optional
        Its experiment; default: the ``.psyexp`` beside it (same name, or its ``expName``).

    Returns
    -------
    names : list of str
        Components written as ``# Unknown component ignored: NAME`` that the ``.psyexp`` beside
        the script (same name, or the script's ``expName``) declares as Thermal cue components;
        empty when there are none or no ``.psyexp`` is found.
    psyexp : Path or None
    """
    script = Path(script)
    try:
        text = script.read_text(encoding="utf-8-sig", errors="replace")
    except OSError:
        return [], None
    ignored = _IGNORED.findall(text)
    if not ignored:
        return [], None
    for psyexp in ([Path(psyexp)] if psyexp is not None else _psyexp_beside(script, text)):
        try:
            root = ET.parse(psyexp).getroot()
        except (ET.ParseError, OSError):
            continue
        ours = {el.get("name") for el in root.iter(COMPONENT_TAG)}
        names = [n for n in ignored if n in ours]
        if names:
            return names, psyexp
    return [], None


def check_main_script(main=None) -> None:
    """Exit with the fix when the running script was compiled without this plugin.

    Parameters
    ----------
    main : module, optional
        The running script's module (default ``sys.modules["__main__"]``).

    Raises
    ------
    SystemExit
        With one line naming the script, the components left out and the command that compiles
        the experiment with them.
    """
    main = sys.modules.get("__main__") if main is None else main
    path = getattr(main, "__file__", None)
    if not path or not str(path).endswith(".py"):
        return
    names, psyexp = left_out_components(path)
    if not names:
        return
    raise SystemExit(
        f"thermocue: {path}: compiled without the thermocue plugin: PsychoPy left out the Thermal "
        f"cue component(s) {', '.join(repr(n) for n in names)} (python -m "
        f"psychopy.scripts.psyexpCompile does not activate plugins); compile it with "
        f"`thermocue psyexp compile {psyexp}` (or from the Builder app), then run it again")

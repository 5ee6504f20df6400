"""PsychoPy's experiment-info dialog when its toolkit cannot start: asked on the terminal instead.

A Builder experiment with "Show info dlg" (on by default) calls ``psychopy.gui.DlgFromDict``
before its window opens. PsychoPy draws that dialog with PyQt6, which it requires (wxPython,
which has no Linux wheel, only when no PyQt is installed). Qt opens windows on X through its
``xcb`` platform plugin, which needs the system's xcb libraries (on Debian ``libxcb-cursor0``,
``libxcb-icccm4``, ``libxcb-keysyms1``, ...; ``scripts/setup`` installs them); without them Qt
aborts the whole process (SIGABRT, "no Qt platform plugin could be initialized"), which Python
cannot catch.

:func:`install` runs when the plugin is activated (the first lines of every Builder script) and
wraps ``psychopy.gui.DlgFromDict``. The wrapper's first call checks, in a child process, that Qt
can start (``QApplication``); if it can, PsychoPy's own dialog opens, unchanged. If it cannot, the
same fields are asked on the terminal when standard input is one (Enter keeps the value shown);
with no terminal the script stops with one line naming Qt's reason and the fixes (install the
libraries, or turn "Show info dlg" off), exit status 1. Where PsychoPy uses wxPython (the
Builder app itself) nothing changes.
"""
from __future__ import annotations

import os
import subprocess
import sys

__all__ = ["install", "qt_problem", "TerminalDlgFromDict", "QT_LIBRARIES"]

#: Debian's packages of the libraries Qt's xcb platform plugin loads (PyQt6 6.11).
QT_LIBRARIES = ("libxcb-cursor0 libxcb-icccm4 libxcb-keysyms1 libxcb-image0 libxcb-render-util0 "
                "libxcb-randr0 libxcb-shape0 libxcb-xkb1 libxkbcommon-x11-0 libegl1 libfontconfig1")

_PROBE = "from {lib} import QtWidgets; QtWidgets.QApplication([])"
_checked: dict = {}


def qt_problem(lib: str = "PyQt6", timeout_s: float = 60.0) -> str | None:
    """Why Qt cannot start here, in its own words; None when it can (checked once per process).

    The check runs ``QApplication([])`` of ``lib`` (PsychoPy's ``gui.haveQt``) in a child
    process with this process's environment (``DISPLAY``, ``QT_QPA_PLATFORM``), since a Qt that
    cannot start aborts its process.

    Parameters
    ----------
    lib : str
        The Qt binding PsychoPy's ``gui`` uses (``"PyQt6"`` or ``"PyQt5"``).
    timeout_s : float, s
        How long the child process may take to start Qt.

    Returns
    -------
    str or None
        Qt's own message (its ``qt.qpa.*`` lines, else its last line), or None.
    """
    if "problem" not in _checked:
        try:
            import importlib
            widgets = importlib.import_module(f"{lib}.QtWidgets")
            if widgets.QApplication.instance() is not None:
                _checked["problem"] = None          # Qt is already running in this process
                return None
        except ImportError as exc:
            _checked["problem"] = f"{lib} cannot be imported ({exc})"
            return _checked["problem"]
        try:
            run = subprocess.run([sys.executable, "-c", _PROBE.format(lib=lib)],
                                 capture_output=True, text=True, timeout=timeout_s,
                                 stdin=subprocess.DEVNULL)
            problem = None
            if run.returncode != 0:
                lines = [ln.strip() for ln in run.stderr.splitlines() if ln.strip()]
                why = [ln for ln in lines if ln.startswith("qt.qpa.")] or lines[-1:]
                problem = "; ".join(why) or f"exit status {run.returncode}"
        except subprocess.TimeoutExpired:
            problem = f"QApplication did not start within {timeout_s:g} s"
        _checked["problem"] = problem
    return _checked["problem"]


def _convert(text: str, initial):
    """``text`` typed for a field whose value was ``initial``: the same type where it parses."""
    if isinstance(initial, bool):
        return text.strip().lower() in ("1", "true", "yes", "y")
    for kind in (int, float):
        if isinstance(initial, kind):
            try:
                return kind(text)
            except ValueError:
                return text
    return text


class TerminalDlgFromDict:
    """``psychopy.gui.DlgFromDict`` asked on the terminal (prompts on stderr, answers on stdin).

    Same parameters as PsychoPy's (``screen`` and ``alwaysOnTop`` do nothing here). Each field
    is asked in the dialog's order with its value shown; Enter keeps it; a list offers its
    choices (Enter: the first); fixed fields are shown, hidden ones kept; a required field
    (``|req``) is asked again while empty. End of input (Ctrl-D) or Ctrl-C is Cancel
    (``OK = False``, the dictionary unchanged), as in PsychoPy.

    Attributes
    ----------
    OK : bool
    dictionary : dict
    data : list
        The values in the order asked.
    """

    def __init__(self, dictionary, title="", fixed=None, order=None, tip=None, screen=-1,
                 sortKeys=True, copyDict=False, labels=None, show=True, alwaysOnTop=False,
                 reason: str = ""):
        from psychopy.gui import util
        self.dictionary = dictionary.copy() if copyDict else dictionary
        self.title = title
        self.reason = reason
        self.OK = False
        self.data = []
        self._params = [p for p in util.makeDisplayParams(
            self.dictionary, sortKeys=sortKeys, labels=labels, tooltips=tip, order=order,
            fixed=fixed) if p != "---"]
        if show:
            self.show()

    def _ask(self, prompt: str) -> str:
        print(prompt, end="", file=sys.stderr, flush=True)
        line = sys.stdin.readline()
        if not line:
            raise EOFError
        return line.rstrip("\r\n")

    def show(self):
        """Ask every field; return the dictionary (updated only on OK)."""
        print(f"{self.title or 'Experiment info'}: PsychoPy's dialog cannot open ({self.reason}); "
              "answer here (Enter keeps the value shown, Ctrl-D cancels)", file=sys.stderr)
        values = {}
        try:
            for p in self._params:
                key, label, value, flags = p["key"], p["label"], p["value"], p["flags"]
                if "hid" in flags:
                    continue
                if "fix" in flags:
                    print(f"  {label}: {value}", file=sys.stderr)
                    continue
                while True:
                    if isinstance(value, (list, tuple)) and not value:
                        # an empty list offers nothing to choose: asked as free text
                        answer = self._ask(f"  {label} []: ")
                    elif isinstance(value, (list, tuple)):
                        answer = self._ask(f"  {label} [{' / '.join(map(str, value))}; Enter: "
                                           f"{value[0]}]: ") or str(value[0])
                        if answer not in map(str, value):
                            print(f"  expected one of {', '.join(map(str, value))}", file=sys.stderr)
                            continue
                        answer = next(v for v in value if str(v) == answer)
                    else:
                        typed = self._ask(f"  {label} [{value}]: ")
                        answer = _convert(typed, value) if typed else value
                    if "req" in flags and str(answer).strip() == "":
                        print(f"  {label} is required", file=sys.stderr)
                        continue
                    break
                values[key] = answer
        except (EOFError, KeyboardInterrupt):
            print("", file=sys.stderr)
            self.OK = False
            return self.dictionary
        self.dictionary.update(values)
        self.data = list(values.values())
        self.OK = True
        return self.dictionary


def _fallback(reason: str, args, kwargs):
    title = kwargs.get("title", args[1] if len(args) > 1 else "")
    if sys.stdin is not None and sys.stdin.isatty():
        return TerminalDlgFromDict(*args, reason=reason, **kwargs)
    script = os.path.abspath(sys.argv[0]) if sys.argv and sys.argv[0] else "this script"
    print(f"thermocue: {script}: PsychoPy's experiment-info dialog ({title!r}) cannot open: Qt "
          f"cannot start ({reason}); install Qt's X11 libraries (scripts/setup; on Debian: "
          f"apt-get install {QT_LIBRARIES}), or turn off \"Show info dlg\" in the experiment's "
          "settings, or run the script from a terminal to answer there", file=sys.stderr)
    sys.exit(1)


def install() -> None:
    """Wrap ``psychopy.gui.DlgFromDict`` (once): PsychoPy's dialog when Qt can start, else
    :class:`TerminalDlgFromDict` or one line and exit status 1 (see the module's notes)."""
    from psychopy import gui
    original = getattr(gui, "DlgFromDict", None)
    if getattr(original, "_thermocue_wrapped", False):
        return
    if original is not None and not gui.haveQt:
        return                       # wxPython's dialog (the Builder app): not ours to change

    def DlgFromDict(*args, **kwargs):
        reason = ("neither PyQt nor wxPython can be imported" if original is None
                  else qt_problem(gui.haveQt))
        if reason is None:
            return original(*args, **kwargs)
        return _fallback(reason, args, kwargs)

    DlgFromDict._thermocue_wrapped = True
    DlgFromDict.__doc__ = (original.__doc__ if original is not None else "") + (
        "\n\n(thermocue's plugin: asked on the terminal when Qt cannot start here.)")
    DlgFromDict.original = original
    gui.DlgFromDict = DlgFromDict

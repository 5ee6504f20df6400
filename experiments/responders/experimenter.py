"""The experimenter's channel: what only the experimenter may see (and their confirmations).

The participant's screen (the responder) never names the sample. Which sample to place, trial
numbers, progress and time remaining, faults and skin-temperature warnings go here instead:

``TerminalExperimenter`` (the default)
    One line per message on the session's error stream (stderr), ``thermocue: ...``;
    confirmations are asked on the controlling terminal when there is one.
``WindowExperimenter`` (``thermocue run --experimenter-screen N``)
    The same lines in a second PsychoPy window on screen ``N``, also echoed on stderr.
"""
from __future__ import annotations

import os
import sys

__all__ = ["Experimenter", "TerminalExperimenter", "WindowExperimenter", "make_experimenter"]


class Experimenter:
    """Base class: :meth:`tell` a line, :meth:`confirm` a question."""

    def __init__(self, out=None):
        self._out = out

    @property
    def out(self):
        return self._out if self._out is not None else sys.stderr

    def open(self) -> None:
        """Called once before the session's first line (a window opens here)."""

    def close(self) -> None:
        """Called once at the end of the session."""

    def tell(self, text: str) -> None:
        """Show one line to the experimenter."""
        print(f"thermocue: {text}", file=self.out, flush=True)

    def progress(self, text: str) -> None:
        """A progress line of the session (already logged on ``thermocue.session``, which the
        CLI prints on stderr): shown again only where the experimenter has a screen."""

    def confirm(self, question: str) -> bool | None:
        """Ask a yes/no question; True or False, or None when nobody can be asked.

        Asked on the controlling terminal (``/dev/tty``) when stdin is a terminal (someone
        typed the command); with none (a pipeline, a test under pytest, a batch job) the answer
        is None and the caller decides (it logs that the question went unanswered).
        """
        try:
            if not os.isatty(0):
                return None
        except OSError:
            return None
        try:
            fd = os.open("/dev/tty", os.O_RDWR | os.O_NOCTTY)
        except OSError:
            return None
        try:
            if not os.isatty(fd):
                return None
            os.write(fd, f"thermocue: {question} [y/N] ".encode())
            line = b""
            while not line.endswith((b"\n", b"\r")):
                chunk = os.read(fd, 1)
                if not chunk:
                    break
                line += chunk
        finally:
            os.close(fd)
        return line.decode(errors="replace").strip().lower() in ("y", "yes")


class TerminalExperimenter(Experimenter):
    """The terminal (stderr) as the experimenter's channel."""


class WindowExperimenter(Experimenter):
    """A second PsychoPy window on screen ``screen`` showing the experimenter's latest lines.

    Parameters
    ----------
    screen : int
        PsychoPy's ``screen`` number (an X screen, e.g. ``:0.1``).
    size : tuple of int, px
    lines : int
        How many of the latest lines are shown.
    """

    def __init__(self, screen: int, out=None, size=(900, 600), lines: int = 14):
        super().__init__(out)
        self.screen = int(screen)
        self.size = tuple(int(v) for v in size)
        self.lines = int(lines)
        self._history: list[str] = []
        self.win = None
        self._stim = None

    def open(self) -> None:
        from experiments.errors import SessionError
        try:
            from psychopy import visual
            self.win = visual.Window(size=self.size, fullscr=False, screen=self.screen,
                                     title="thermocue experimenter", checkTiming=False,
                                     units="height", color=(-0.8,) * 3)
        except Exception as exc:
            raise SessionError(f"--experimenter-screen {self.screen}: expected a screen to open "
                               f"the experimenter's window on (DISPLAY="
                               f"{os.environ.get('DISPLAY')!r}), got {type(exc).__name__}: "
                               f"{exc}") from None
        self._stim = visual.TextStim(self.win, text="", height=0.03, wrapWidth=1.4,
                                     alignText="left", anchorHoriz="center", pos=(0, 0))

    def close(self) -> None:
        if self.win is not None:
            try:
                self.win.close()
            finally:
                self.win = None

    def tell(self, text: str) -> None:
        super().tell(text)
        self._show(text)

    def progress(self, text: str) -> None:
        self._show(text)

    def _show(self, text: str) -> None:
        self._history = (self._history + [text])[-self.lines:]
        if self.win is not None:
            self._stim.text = "\n".join(self._history)
            self._stim.draw()
            self.win.flip()


def make_experimenter(screen: int | None = None, out=None) -> Experimenter:
    """The terminal channel, or a window on ``screen`` when a screen number is given."""
    if screen is None:
        return TerminalExperimenter(out)
    return WindowExperimenter(screen, out)

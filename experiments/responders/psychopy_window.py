"""The PsychoPy window responder: instructions, prompts, progress, keyboard answers, sound cue.

PsychoPy is imported inside :meth:`PsychopyResponder.begin_session` only (``import
psychopy.visual`` takes about 3 s and needs an X display). Answers come from
``psychopy.hardware.keyboard.Keyboard`` with the ``ptb`` backend: if psychtoolbox cannot load
(e.g. ``libjack.so.0`` is missing) PsychoPy silently falls back to the ``event`` backend, whose
``waitKeys(keyList=...)`` never matches, so the backend in use is logged and a fallback is
refused (``require_ptb=True``). The cue uses ``psychopy.sound`` with the ``sounddevice`` library;
with no audio device it becomes a logged no-op.
"""
from __future__ import annotations

import os
import sys
import time

from experiments.errors import SessionError
from experiments.responders.base import RESPONSE_IDS, Responder, ResponderClosed, Response

__all__ = ["PsychopyResponder", "WINDOW_TITLE"]

#: The window title (tests find the window with ``xdotool search --name thermocue``).
WINDOW_TITLE = "thermocue"

_CONFIRM_KEYS = ["space", "return"]
_QUIT_KEYS = ["escape"]


class PsychopyResponder(Responder, name="psychopy", aliases=("window",)):
    """Answers from the keyboard in a PsychoPy window.

    Parameters
    ----------
    fullscr : bool
        Full screen (the lab), or a window of ``size`` pixels (tests, demos).
    size : tuple of int, px
    check_timing : bool
        PsychoPy's frame-rate measurement at window creation; meaningless without vsync
        (Xvfb), so off by default.
    audio_lib : str
        PsychoPy ``audioLib`` preference for the cue (``"sounddevice"`` plays to ALSA's null
        device when there is no sound card; ``"ptb"`` does not).
    cue_hz, cue_s : float, Hz / s
        The cue tone.
    max_wait_s : float or None, s
        Give up waiting for a key after this long (raises :class:`ResponderClosed`); None waits
        for ever.
    require_ptb : bool
        Refuse to run on a keyboard backend other than ``ptb``.

    Notes
    -----
    ``rt_s`` is measured by the keyboard's clock from the flip that shows the question to the
    key going down; the key counts once released (``waitRelease=True``: with ``False`` the
    ptb backend reports a press again at its release), and keys pressed before the question
    was shown are ignored. Escape ends the session (resumable).
    """

    def __init__(self, fullscr: bool = False, size=(1024, 768), check_timing: bool = False,
                 audio_lib: str = "sounddevice", cue_hz: float = 880.0, cue_s: float = 0.2,
                 max_wait_s: float | None = None, require_ptb: bool = True):
        super().__init__()
        self.fullscr = bool(fullscr)
        self.size = tuple(int(v) for v in size)
        self.check_timing = bool(check_timing)
        self.audio_lib = audio_lib
        self.cue_hz = float(cue_hz)
        self.cue_s = float(cue_s)
        self.max_wait_s = max_wait_s
        self.require_ptb = require_ptb
        self.win = None
        self.kb = None
        self.keyboard_backend = None
        self._sound = None
        self._main_text = ""
        self._progress_text = ""

    # -- life cycle -----------------------------------------------------------------------
    def begin_session(self, session) -> None:
        super().begin_session(session)
        from psychopy import prefs
        prefs.hardware["audioLib"] = [self.audio_lib]
        from psychopy import core
        from psychopy.hardware import keyboard

        self._core = core
        try:
            from psychopy import visual  # needs an X display already at import
            self.win = visual.Window(size=self.size, fullscr=self.fullscr, title=WINDOW_TITLE,
                                     checkTiming=self.check_timing, units="height",
                                     color=(-0.6,) * 3, allowGUI=not self.fullscr)
        except Exception as exc:   # pyglet's NoSuchDisplayException, GL errors
            raise SessionError(f"--responder psychopy: expected a display to open a window on "
                               f"(DISPLAY={os.environ.get('DISPLAY')!r}), got "
                               f"{type(exc).__name__}: {exc}") from None
        self._stim = visual.TextStim(self.win, text="", height=0.045, wrapWidth=1.2, pos=(0, 0.05))
        self._footer = visual.TextStim(self.win, text="", height=0.03, wrapWidth=1.3,
                                       pos=(0, -0.43), color=(0.3, 0.3, 0.3))
        self.kb = keyboard.Keyboard(backend="ptb")
        self.keyboard_backend = self.kb.getBackend()
        self.log("keyboard", backend=self.keyboard_backend)
        if self.keyboard_backend != "ptb":
            msg = (f"keyboard backend is {self.keyboard_backend!r}, not 'ptb' "
                   "(psychtoolbox failed to load; is libjack-jackd2-0 installed?)")
            print(f"thermocue: warning: {msg}", file=sys.stderr)
            if self.require_ptb:
                self.end_session()
                raise SessionError(f"--responder psychopy: {msg}")
        self._make_sound()
        self.show_text("thermocue\n\nThe session will start in a moment.")

    def end_session(self) -> None:
        if self.win is not None:
            try:
                self.win.close()
            finally:
                self.win = None

    def _make_sound(self) -> None:
        try:
            from psychopy import sound
            self._sound = sound.Sound(self.cue_hz, secs=self.cue_s, stereo=True)
            self.log("audio", backend=getattr(sound, "audioLib", self.audio_lib), ok=True)
        except Exception as exc:  # any audio failure means "no cue", never "no session"
            self._sound = None
            reason = f"no audio output via {self.audio_lib} ({type(exc).__name__}: {exc})"
            self.log("cue_unavailable", reason=reason)
            print(f"thermocue: warning: {reason}; the sound cue is off", file=sys.stderr)

    # -- drawing and keys -------------------------------------------------------------------
    def _draw(self) -> None:
        self._stim.text = self._main_text
        self._footer.text = self._progress_text
        self._stim.draw()
        self._footer.draw()
        self.win.flip()

    def _wait(self, keys: list[str]):
        """Wait for one of ``keys`` (or escape); return the key press.

        The ptb keyboard reads the X server's queue itself: no window event pumping needed.
        """
        start = time.monotonic()
        self.log("awaiting_key", keys=keys)   # experimenters' record; tests wait for it
        while True:
            pressed = self.kb.getKeys(keyList=keys + _QUIT_KEYS, waitRelease=True)
            for key in pressed:
                if key.rt is None or key.rt < 0:
                    continue      # pressed before the question was shown
                if key.name in _QUIT_KEYS:
                    raise ResponderClosed("escape pressed in the PsychoPy window")
                return key
            if self.max_wait_s is not None and time.monotonic() - start > self.max_wait_s:
                raise ResponderClosed(f"no key pressed within {self.max_wait_s} s")
            self._core.wait(0.005, hogCPUperiod=0)

    # -- the Responder interface -------------------------------------------------------------
    def show_text(self, text: str) -> None:
        self._main_text = text
        self._draw()

    def progress(self, text: str) -> None:
        self._progress_text = text
        self._draw()

    def prompt_experimenter(self, text: str) -> None:
        self._main_text = f"{text}\n\n(experimenter: press space when ready)"
        self.kb.clearEvents()
        self.win.callOnFlip(self.kb.clock.reset)
        self._draw()
        self._wait(_CONFIRM_KEYS)

    def cue(self) -> bool:
        self._main_text = "Touch now"
        self._draw()
        if self._sound is None:
            self.log("cue_unavailable", reason="no audio device")
            return False
        try:
            self._sound.play()
            return True
        except Exception as exc:
            self.log("cue_unavailable", reason=f"{type(exc).__name__}: {exc}")
            return False

    def rewarm(self, seconds: float) -> None:
        """A countdown in the window (escape still ends the session); none on a virtual clock."""
        if seconds <= 0:
            return
        end = time.monotonic() + seconds
        self.kb.clearEvents()
        while (left := end - time.monotonic()) > 0:
            self._main_text = f"Rewarm your finger on the hot-water bag\n\n{left:.0f} s"
            self._draw()
            if self.kb.getKeys(keyList=_QUIT_KEYS, waitRelease=False):
                raise ResponderClosed("escape pressed in the PsychoPy window")
            self._core.wait(min(0.25, left), hogCPUperiod=0)

    def respond(self, trial, stimulus) -> Response:
        choices = [str(i) for i in RESPONSE_IDS]
        self._main_text = f"Which roughness? Press {', '.join(choices)}"
        self.kb.clearEvents()
        self.win.callOnFlip(self.kb.clock.reset)  # rt_s from the flip showing the question
        self._draw()
        key = self._wait(choices)
        return Response(int(key.name), float(key.rt), source=f"keyboard:{self.keyboard_backend}")

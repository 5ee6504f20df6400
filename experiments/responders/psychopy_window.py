"""The PsychoPy window responder: instructions, prompts, progress, keyboard answers, sound cue.

PsychoPy is imported inside :meth:`PsychopyResponder.begin_session` only (``import
psychopy.visual`` takes about 3 s and needs an X display). Answers come from
``psychopy.hardware.keyboard.Keyboard`` with the ``ptb`` backend: if psychtoolbox cannot load
(e.g. ``libjack.so.0`` is missing) PsychoPy silently falls back to the ``event`` backend, whose
``waitKeys(keyList=...)`` never matches, so the backend in use is logged and a fallback is
refused (``require_ptb=True``). The cue uses ``psychopy.sound`` with the ``sounddevice`` library;
with no audio device it becomes a logged no-op.

The window is the participant's: it shows only instructions, "please wait", the sample's name
where the protocol's block gives it (familiarisation), the cue, the question, feedback where the
block says ``feedback = true``, the rewarming countdown and the goodbye. Each text stays up at
least the protocol's ``[presentation] text_min_s`` (instructions ``instructions_min_s``, then
until a key), and every text's first and last frame are logged (``text_on`` / ``text_off``
events with PsychoPy's flip times, ``core.getTime()`` seconds).
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
_UNDO_KEYS = ["backspace"]
_QUIT_KEYS = ["escape"]

#: What the participant's window shows, state by state (docs/session.md, docs/screens/).
TEXTS = {
    "welcome": "The session will start in a moment.",
    "please_wait": "Please wait",
    "cue": "Touch now",
    "question": "Which sample? Press {choices}",
    "instructions_key": "Press space to continue",
    "finished": "Thank you: the session is finished.",
}


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
    question_cue_hz, question_cue_s : float, Hz / s
        The question's tone in the spoken-answer mode (lower and longer than the touch cue).

    Notes
    -----
    ``rt_s`` is measured by the keyboard's clock from the flip that shows the question to the
    key going down; the key counts once released (``waitRelease=True``: with ``False`` the
    ptb backend reports a press again at its release), and keys pressed before the question
    was shown are ignored. Escape ends the session (resumable).

    With the protocol's ``[presentation] answer_mode = "spoken"`` (the paper's procedure) the
    window stays blank for the whole session (no text is drawn); the touch cue sounds as usual
    and a second tone asks the question (at contact with ``answer_during_contact``, else once
    the contact has been recorded). Everything the participant would have read goes to the
    experimenter's channel (terminal or ``--experimenter-screen``), who keys the spoken answer
    1-4 on the keyboard, then confirms it with space/return or undoes it with backspace. The
    answer is timed by the keyboard's clock, reset when the question's tone is started, to the
    confirmed digit's key press (``answer_keyed_after_cue_s``).
    """

    def __init__(self, fullscr: bool = False, size=(1024, 768), check_timing: bool = False,
                 audio_lib: str = "sounddevice", cue_hz: float = 880.0, cue_s: float = 0.2,
                 max_wait_s: float | None = None, require_ptb: bool = True,
                 question_cue_hz: float = 440.0, question_cue_s: float = 0.5):
        super().__init__()
        self.fullscr = bool(fullscr)
        self.size = tuple(int(v) for v in size)
        self.check_timing = bool(check_timing)
        self.audio_lib = audio_lib
        self.cue_hz = float(cue_hz)
        self.cue_s = float(cue_s)
        self.max_wait_s = max_wait_s
        self.require_ptb = require_ptb
        self.question_cue_hz = float(question_cue_hz)
        self.question_cue_s = float(question_cue_s)
        self.spoken = False
        self._question_sound = None
        self._cued = None          # trial index whose question tone has sounded
        self.win = None
        self.kb = None
        self.keyboard_backend = None
        self._sound = None
        self._main_text = ""
        self._state = ""
        self._label = None
        self._on = None            # (state, text, flip time) of the text on screen
        self.psychopy_version = None
        self.frame_rate = None

    # -- life cycle -----------------------------------------------------------------------
    def begin_session(self, session) -> None:
        super().begin_session(session)
        from psychopy import prefs
        prefs.hardware["audioLib"] = [self.audio_lib]
        import psychopy
        from psychopy import core
        from psychopy.hardware import keyboard

        self.psychopy_version = psychopy.__version__   # the trials table's psychopyVersion

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
        # PsychoPy's frameRate (as a Builder script measures it; None when it cannot: no vsync)
        try:
            rate = self.win.getActualFrameRate(nIdentical=10, nMaxFrames=120, nWarmUpFrames=10)
        except Exception:
            rate = None
        self.frame_rate = None if rate is None else round(float(rate), 3)
        self.log("frame_rate", frameRate=self.frame_rate)
        self._stim = visual.TextStim(self.win, text="", height=0.045, wrapWidth=1.2, pos=(0, 0.05))
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
        shown = getattr(getattr(session, "protocol", None), "presentation", None)
        self.spoken = getattr(shown, "answer_mode", "keyed") == "spoken"
        self._make_sound()
        if self.spoken:
            self._question_sound = self._tone(self.question_cue_hz, self.question_cue_s)
            self.log("participant_screen", blank=True, answer_mode="spoken")
        self._show("welcome", TEXTS["welcome"])

    def end_session(self) -> None:
        if self.win is not None:
            try:
                self._clear()     # the last text (the goodbye) up its minimum, then a blank frame
            except Exception:     # closing must not fail on a window already gone
                self._log_off()
            try:
                self.win.close()
            finally:
                self.win = None

    def _tone(self, hz: float, secs: float):
        """A ``psychopy.sound.Sound``, or None when there is no audio (already reported)."""
        if self._sound is None:
            return None
        from psychopy import sound
        try:
            return sound.Sound(hz, secs=secs, stereo=True)
        except Exception as exc:
            self.log("cue_unavailable", reason=f"question tone: {type(exc).__name__}: {exc}")
            return None

    def _tell(self, text: str) -> None:
        """A line on the experimenter's channel (terminal, or their screen)."""
        experimenter = getattr(self.session, "experimenter", None)
        if experimenter is not None:
            experimenter.tell(text)
        else:
            print(text, file=sys.stderr, flush=True)

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
    def _min_s(self, state: str) -> float:
        """The protocol's shortest time on screen for a text in ``state``."""
        shown = getattr(getattr(self.session, "protocol", None), "presentation", None)
        if shown is None:
            return 0.0
        return shown.instructions_min_s if state == "instructions" else shown.text_min_s

    def _left_s(self) -> float:
        """How long the text on screen must stay up yet (its state's minimum from its first
        flip), s; 0 when there is none."""
        if self._on is None:
            return 0.0
        return self._on[2] + self._min_s(self._on[0]) - self._core.getTime()

    def _hold(self) -> None:
        """Wait until the text on screen has been up its minimum (``core.wait`` never returns
        early: it sleeps, then spins on ``core.getTime``)."""
        left = self._left_s()
        if left > 0:
            self._core.wait(left, hogCPUperiod=0)

    def _show(self, state: str, text: str, wait: bool = True) -> None:
        """Replace the text on screen by ``text`` once the old one has been up its minimum
        (``wait=False``: the caller has checked :meth:`_left_s` itself, e.g. in the telemetry
        loop, which must not block)."""
        if wait and self._on is not None and self._on[0] != state:
            self._hold()
        self._state, self._main_text = state, text
        self._draw()

    def _clear(self) -> None:
        """Take the text down (after its minimum): a blank frame, logged as its ``text_off``."""
        if self._on is None:
            return
        self._hold()
        self._state, self._main_text = "", ""
        t = self.win.flip()
        self._log_off(float(t) if t is not None else self._core.getTime())

    def _draw(self) -> float:
        """Draw the current text and flip; log a new text's first frame; return the flip time.

        In the spoken-answer mode the window stays blank: a flip, nothing drawn or logged."""
        if self.spoken:
            t = self.win.flip()
            return float(t) if t is not None else self._core.getTime()
        self._stim.text = self._main_text
        self._stim.draw()
        t = self.win.flip()
        t = float(t) if t is not None else self._core.getTime()
        if self._on is None or self._on[0] != self._state:
            self._log_off(t)
            self._on = (self._state, self._main_text, t)
            self.log("text_on", state=self._state, text=self._main_text, flip_s=round(t, 4))
        return t

    def _log_off(self, t: float | None = None) -> None:
        """Log that the text on screen left it (at flip time ``t``)."""
        if self._on is None:
            return
        if t is None:
            t = self._core.getTime()
        state, text, t_on = self._on
        self._on = None
        self.log("text_off", state=state, flip_s=round(t, 4), shown_s=round(t - t_on, 4))

    def _wait(self, keys: list[str], **note):
        """Wait for one of ``keys`` (or escape); return the key press.

        The ptb keyboard reads the X server's queue itself: no window event pumping needed.
        ``note``: extra fields of the ``awaiting_key`` event (e.g. ``purpose``).
        """
        start = time.monotonic()
        self.log("awaiting_key", keys=keys, **note)   # experimenters' record; tests wait for it
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
        """A text for the participant (the goodbye); in the spoken-answer mode the window stays
        blank and the experimenter is told to say it."""
        state = "finished" if text == TEXTS["finished"] else "text"
        if self.spoken:
            self._tell(f"say to the participant: {text!r}")
        self._show(state, text)

    def show_instructions(self, text: str, min_s: float = 0.0, until_key: bool = False) -> None:
        """The block's instructions: up at least ``min_s`` s, then (``until_key``) until space.

        Spoken-answer mode: the experimenter reads them out and goes on with space."""
        if self.spoken:
            self._tell(f"read to the participant: {text!r}; then press space")
            self.kb.clearEvents()
            self.kb.clock.reset()
            self._wait(_CONFIRM_KEYS, purpose="instructions_read")
            return
        self._show("instructions", text)
        t_on = self._on[2]
        left = t_on + min_s - self._core.getTime()
        if left > 0:
            self._core.wait(left, hogCPUperiod=0)
        if until_key:
            self._state = "instructions"
            self._main_text = f"{text}\n\n{TEXTS['instructions_key']}"
            self.kb.clearEvents()
            self.win.callOnFlip(self.kb.clock.reset)
            self._draw()
            self._wait(_CONFIRM_KEYS)

    def please_wait(self) -> None:
        if self._label is None:
            self._show("please_wait", TEXTS["please_wait"])

    def show_label(self, text: str | None) -> None:
        self._label = text
        if text and self.spoken:
            self._tell(f"say to the participant: {text!r}")
        elif text:
            self._show("label", text)

    def feedback(self, text: str, seconds: float = 0.0) -> None:
        if self.spoken:
            self._tell(f"say to the participant: {text!r}")
            return
        self._show("feedback", text)
        if seconds > 0:
            self._core.wait(seconds, hogCPUperiod=0)

    def progress(self, text: str) -> None:
        """The experimenter's line: never drawn in the participant's window."""

    def prompt_experimenter(self, text: str) -> None:
        """Wait for the experimenter's space (the window keeps saying "please wait")."""
        if self._state != "please_wait":
            self._show("please_wait", TEXTS["please_wait"])
        self.kb.clearEvents()
        self.win.callOnFlip(self.kb.clock.reset)
        self._draw()
        self._wait(_CONFIRM_KEYS)

    def cue(self) -> bool:
        # A familiarisation label stays up with the cue for the whole touch.
        self._show("cue", TEXTS["cue"] if not self._label else f"{self._label}\n\n{TEXTS['cue']}")
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
        if self.spoken:
            self._tell(f"the participant rewarms the finger on the hot-water bag ({seconds:.0f} s)")
            end = self._core.getTime() + seconds
            self.kb.clearEvents()
            while (left := end - self._core.getTime()) > 0:
                self._draw()
                if self.kb.getKeys(keyList=_QUIT_KEYS, waitRelease=False):
                    raise ResponderClosed("escape pressed in the PsychoPy window")
                self._core.wait(min(0.25, left), hogCPUperiod=0)
            return
        self._show("rewarm", f"Rewarm your finger on the hot-water bag\n\n{seconds:.0f} s")
        end = self._on[2] + seconds
        self.kb.clearEvents()
        while (left := end - self._core.getTime()) > 0:
            self._state = "rewarm"
            self._main_text = f"Rewarm your finger on the hot-water bag\n\n{left:.0f} s"
            self._draw()
            if self.kb.getKeys(keyList=_QUIT_KEYS, waitRelease=False):
                raise ResponderClosed("escape pressed in the PsychoPy window")
            self._core.wait(min(0.25, left), hogCPUperiod=0)

    def _ask(self, wait: bool = True) -> None:
        choices = [str(i) for i in RESPONSE_IDS]
        # rt_s runs from the first frame showing the question: the keyboard clock is reset
        # by that flip (keys pressed before it have rt < 0 and are ignored).
        self.kb.clearEvents()
        self.win.callOnFlip(self.kb.clock.reset)
        self._show("question", TEXTS["question"].format(choices=", ".join(choices)), wait=wait)

    def _question_cue(self, trial) -> None:
        """Spoken-answer mode: the question's tone; the keyboard's clock is reset as it starts
        (keys pressed before it are ignored)."""
        self.kb.clearEvents()
        self.kb.clock.reset()
        played = False
        if self._question_sound is not None:
            try:
                self._question_sound.play()
                played = True
            except Exception as exc:
                self.log("cue_unavailable", reason=f"question tone: {type(exc).__name__}: {exc}")
        self._cued = trial.trial_index
        self.log("question_cue", trial_index=trial.trial_index, played=played)
        self._tell(f"trial {trial.trial_index}: question asked; key the participant's spoken "
                   f"answer 1-4, then space/return to confirm or backspace to undo")

    def _keyed_answer(self, trial) -> Response:
        """Spoken-answer mode: the experimenter keys the answer, then confirms or undoes it."""
        digits = [str(i) for i in RESPONSE_IDS]
        key = self._wait(digits, purpose="spoken_answer")
        while True:
            self.log("answer_keyed", trial_index=trial.trial_index, key=key.name,
                     after_cue_s=round(float(key.rt), 4))
            self._tell(f"answer {key.name}: space/return confirms, backspace undoes")
            decision = self._wait(_CONFIRM_KEYS + _UNDO_KEYS + digits, purpose="confirm_answer",
                                  answer=key.name)
            if decision.name in _CONFIRM_KEYS:
                self.log("answer_confirmed", trial_index=trial.trial_index, key=key.name)
                return Response(int(key.name), float(key.rt), answer_mode="spoken",
                                source=f"experimenter:keyboard:{self.keyboard_backend}")
            if decision.name in digits:       # a different digit replaces the one keyed
                self.log("answer_undone", trial_index=trial.trial_index, key=key.name,
                         replaced_by=decision.name)
                key = decision
                continue
            self.log("answer_undone", trial_index=trial.trial_index, key=key.name)
            self._tell("undone: key the answer again")
            key = self._wait(digits, purpose="spoken_answer")

    def begin_answer(self, trial) -> None:
        """The question from the moment of contact (the trace is still being recorded)."""
        if self.spoken:       # the tone now; the experimenter's keys are read in respond()
            self._question_cue(trial)
            return
        self._early = None
        self._asked = trial.trial_index
        self._pending = True       # up as soon as the cue has been up its minimum
        self._ask_when_due()

    def _ask_when_due(self) -> bool:
        """Put the pending question up if the cue has been up its minimum (never waits: runs
        in the telemetry loop); True once it is up."""
        if getattr(self, "_pending", False):
            if self._left_s() > 0:
                return False
            self._pending = False
            self._ask(wait=False)
            self.log("awaiting_key", keys=[str(i) for i in RESPONSE_IDS], during_contact=True)
        return True

    def poll_answer(self, trial):
        if self.spoken or getattr(self, "_asked", None) != trial.trial_index:
            return None
        if not self._ask_when_due():
            return None
        if getattr(self, "_early", None) is None:
            keys = [str(i) for i in RESPONSE_IDS]
            for key in self.kb.getKeys(keyList=keys + _QUIT_KEYS, waitRelease=True):
                if key.rt is not None and key.rt >= 0 and key.name in keys:
                    self._early = Response(int(key.name), float(key.rt),
                                           source=f"keyboard:{self.keyboard_backend}")
                    break
        return self._early

    def respond(self, trial, stimulus) -> Response:
        if self.spoken:
            if self._cued != trial.trial_index:
                self._question_cue(trial)
            self._cued = None
            return self._keyed_answer(trial)
        early = self.poll_answer(trial)
        asked, self._asked = getattr(self, "_asked", None) == trial.trial_index, None
        if early is not None:
            return early
        if asked and getattr(self, "_pending", False):   # contact ended before the cue's minimum
            self._pending = False
            asked = False
        if not asked:
            self._ask()
        key = self._wait([str(i) for i in RESPONSE_IDS])
        return Response(int(key.name), float(key.rt), source=f"keyboard:{self.keyboard_backend}")

"""The responder interface: who answers a trial (a person at a window or console, or a model).

A responder is chosen by name (``--responder psychopy|console|simulated``). Subclasses register
themselves by name when they are defined, in the manner of PsychoPy's
``BaseDevice.__init_subclass__``::

    class ConsoleResponder(Responder, name="console", aliases=("terminal",)):
        ...

:func:`get_responder` looks a name up, importing the module that defines it on first use, so
that neither PsychoPy nor the participant model is imported unless asked for.
"""
from __future__ import annotations

import importlib
import inspect
import math
import time
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from experiments.errors import UserInputError

__all__ = [
    "Response",
    "TrialStimulus",
    "Responder",
    "ResponderClosed",
    "get_responder",
    "responder_names",
    "RESPONSE_IDS",
]

#: The answers a participant may give: the four roughness classes 1#..4#.
RESPONSE_IDS = (1, 2, 3, 4)
#: How an answer is given (the protocol's ``[presentation] answer_mode``).
ANSWER_MODES = ("keyed", "spoken")

#: Responder name -> module of this package that defines it (imported on demand).
_KNOWN_MODULES = {
    "console": "console",
    "psychopy": "psychopy_window",
    "window": "psychopy_window",
    "simulated": "simulated",
}

_REGISTRY: dict[str, type["Responder"]] = {}


class ResponderClosed(Exception):
    """The responder can give no more answers (end of input, window closed, escape key).

    The session treats it like an interruption: display neutral, log closed, resumable.
    """


@dataclass(frozen=True)
class Response:
    """One answer to one trial.

    Parameters
    ----------
    response_id : int
        The roughness class named, 1..4.
    rt_s : float, s
        Response time, from the response prompt to the answer.
    source : str
        What produced it (``"keyboard"``, ``"console"``, ``"simulated"``, ...).
    answer_mode : {"keyed", "spoken"}
        ``"keyed"``: the participant pressed the answer and ``rt_s`` is a response time;
        ``"spoken"``: the participant said it and the experimenter keyed it, so ``rt_s`` is the
        time from the question's sound cue to the experimenter's key (logged as
        ``answer_keyed_after_cue_s``, never as ``rt_s``).
    """

    response_id: int
    rt_s: float
    source: str = "unknown"
    answer_mode: str = "keyed"

    def __post_init__(self):
        if isinstance(self.response_id, bool) or not isinstance(self.response_id, (int, np.integer)) \
                or int(self.response_id) not in RESPONSE_IDS:
            raise ValueError(f"Response: response_id: expected one of {RESPONSE_IDS}, "
                             f"got {self.response_id!r}")
        object.__setattr__(self, "response_id", int(self.response_id))
        rt = float(self.rt_s)
        if not math.isfinite(rt) or rt < 0:
            raise ValueError(f"Response: rt_s: expected a finite time >= 0 s, got {self.rt_s!r}")
        object.__setattr__(self, "rt_s", rt)
        if self.answer_mode not in ANSWER_MODES:
            raise ValueError(f"Response: answer_mode: expected one of {ANSWER_MODES}, "
                             f"got {self.answer_mode!r}")

    def __repr__(self) -> str:
        return f"Response(response_id={self.response_id}, rt_s={self.rt_s:.4f}, source={self.source!r})"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields; the time under the name of what it measured (:meth:`timing`)."""
        return {"response_id": self.response_id, **self.timing(), "source": self.source,
                "answer_mode": self.answer_mode}

    def timing(self) -> dict[str, float | None]:
        """``{"rt_s": ..., "answer_keyed_after_cue_s": ...}``, one of them None: a keyed
        answer's response time, or a spoken answer's time from the question's cue to the
        experimenter's key."""
        spoken = self.answer_mode == "spoken"
        return {"rt_s": None if spoken else self.rt_s,
                "answer_keyed_after_cue_s": self.rt_s if spoken else None}


@dataclass(frozen=True)
class TrialStimulus:
    """What the participant was given on one trial, as recorded.

    Parameters
    ----------
    mode : str
        ``"real"``, ``"simulated"`` or ``"familiarise"``.
    roughness_id : int
        The sample's class, 1..4.
    roughness_um : float, µm
        The sample's roughness Ra.
    time_s, target_C, contact_C : ndarray, s / °C
        The recorded trace from contact on (empty if the trial faulted before contact).
    forces_N : ndarray, N
        Shape ``(n, 4)``, the four force sensors.
    profile_parameters : dict or None
        The target profile's parameters (simulated trials).
    sample : dict or None
        The physical sample placed (real trials).
    status : str
        The recording's status, ``"ok"``, ``"fault"`` or ``"aborted"``.
    """

    mode: str
    roughness_id: int
    roughness_um: float
    time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    target_C: np.ndarray = field(default_factory=lambda: np.zeros(0))
    contact_C: np.ndarray = field(default_factory=lambda: np.zeros(0))
    forces_N: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    profile_parameters: dict | None = None
    sample: dict | None = None
    status: str = "ok"

    @property
    def contact_force_N(self) -> float | None:
        """Mean summed force over the contact, N (:func:`contact_force`), or None."""
        return contact_force(self.time_s, self.forces_N)


#: Summed force, N, from which the finger counts as touching (the session's ``_TOUCH_N``).
TOUCH_N = 0.1


def contact_force(time_s, forces_N) -> float | None:
    """The force the display measured over a trial's contact: the mean summed force, N.

    Parameters
    ----------
    time_s : array_like, s
        Frame times relative to contact (contact at 0).
    forces_N : array_like, N
        Shape ``(n, 4)``: the four force sensors per frame.

    Returns
    -------
    float or None
        The mean of the four sensors' sum over the frames from contact on where the finger
        touches (sum >= :data:`TOUCH_N`); None when there is no such frame.

    Examples
    --------
    >>> contact_force([-0.1, 0.0, 0.1, 0.2], [[0, 0, 0, 0], [1, 1, 0, 0], [1, 1, 1, 1], [0, 0, 0, 0]])
    3.0
    """
    t = np.asarray(time_s, dtype=float).ravel()
    f = np.asarray(forces_N, dtype=float).reshape(-1, 4)
    n = min(t.size, f.shape[0])
    total = f[:n].sum(axis=1)
    on = (t[:n] >= 0) & (total >= TOUCH_N) & np.isfinite(total)
    return float(np.mean(total[on])) if on.any() else None


class Responder:
    """Base class of responders; subclass with ``name=`` (and optional ``aliases=``) to register.

    The session calls, in order: :meth:`begin_session`; at a block's start
    :meth:`show_instructions`; per trial :meth:`progress` (experimenter only),
    :meth:`prompt_experimenter` (real trials), :meth:`show_label` (familiarisation) or
    :meth:`please_wait`, :meth:`touch`, :meth:`cue`, :meth:`respond`, :meth:`feedback`
    (blocks with ``feedback = true``), :meth:`rewarm`; finally :meth:`end_session` (also after
    an interruption).

    Two audiences: whatever a responder shows is seen by the participant. Only
    :meth:`show_instructions`, :meth:`please_wait`, :meth:`show_label`, :meth:`cue`,
    :meth:`respond` (the question), :meth:`feedback`, :meth:`rewarm` and :meth:`show_text`
    (the session's welcome and goodbye) put text there; the sample to place, trial numbers,
    faults, warnings and progress go to the session's experimenter channel
    (:class:`experiments.responders.experimenter.Experimenter`), never through a responder.
    """

    #: The registered name (set by ``__init_subclass__``).
    name: ClassVar[str] = ""
    #: Whether answers come from a person (the session then shows instructions and waits).
    human: ClassVar[bool] = True

    def __init_subclass__(cls, name: str | None = None, aliases: tuple[str, ...] = (), **kwargs):
        super().__init_subclass__(**kwargs)
        if name is None:
            return
        cls.name = name
        for key in (name, *aliases):
            old = _REGISTRY.get(key)
            if old is not None and old is not cls and \
                    (old.__module__, old.__qualname__) != (cls.__module__, cls.__qualname__):
                raise TypeError(f"responder name {key!r} already registered by {old.__qualname__}")
            _REGISTRY[key] = cls

    def __init__(self, **options):
        if options:
            raise UserInputError(f"responder {self.name!r}: unknown option(s) {sorted(options)}")
        self.session = None

    # -- life cycle -----------------------------------------------------------------------
    def begin_session(self, session) -> None:
        """Called once before the first trial; ``session`` is the running :class:`Session`."""
        self.session = session

    def end_session(self) -> None:
        """Called once at the end (normal or interrupted); release windows, devices."""

    # -- experimenter and participant -------------------------------------------------------
    def show_text(self, text: str) -> None:
        """Show ``text`` to the participant (no waiting)."""

    def show_instructions(self, text: str, min_s: float = 0.0, until_key: bool = False) -> None:
        """A block's instructions: on screen at least ``min_s`` s, then until a key if
        ``until_key`` (a person's responder waits; the default just shows them)."""
        self.show_text(text)

    def please_wait(self) -> None:
        """Tell the participant to wait (the experimenter is preparing the trial)."""

    def show_label(self, text: str | None) -> None:
        """Name the sample about to be touched (familiarisation); it stays up, with the cue,
        for the whole touch; ``None`` takes it down."""
        if text:
            self.show_text(text)

    def feedback(self, text: str, seconds: float = 0.0) -> None:
        """Tell the participant whether the answer was right (blocks with ``feedback = true``)."""
        self.show_text(text)

    def progress(self, text: str) -> None:
        """The experimenter's progress line (trial n of N, block, elapsed, ETA).

        Already printed on the experimenter channel; a responder must not show it to the
        participant (the default ignores it)."""

    def prompt_experimenter(self, text: str) -> None:
        """Block until the experimenter confirms they have done ``text`` (place a sample).

        ``text`` has already been shown on the experimenter channel; the participant's screen
        says "please wait" and never ``text`` (it names the sample)."""

    def cue(self) -> bool:
        """Play the sound cue; return False (and log it) if no audio is available."""
        self.log("cue_unavailable", reason="responder has no audio")
        return False

    def touch(self, trial, display) -> None:
        """Before the trial starts: a model scripts the emulator's finger; a person does nothing.

        Against the emulator (capability ``"sim"``) the default stands in for the person's
        hand so that a session can be tried from the window or the console: it places the
        trial's sample (real trials) and presses the emulated finger
        (:meth:`experiments.session.Session.emulated_touch`).
        """
        if self.session is not None and "sim" in _capabilities(display):
            self.session.emulated_touch(trial, display)

    def respond(self, trial, stimulus: TrialStimulus) -> Response:
        """Collect the answer to ``trial`` (1..4) and its response time.

        ``rt_s`` runs from the question's first appearance (its first frame in a window) to
        the answer. After :meth:`begin_answer` the question is already up: the answer may
        already have been given (:meth:`poll_answer`) and the time still counts from then."""
        raise NotImplementedError

    def begin_answer(self, trial) -> None:
        """Put the question up now, during the contact (``[presentation]
        answer_during_contact``); the default does nothing (the question comes after)."""

    def poll_answer(self, trial) -> Response | None:
        """An answer already given to the question put up by :meth:`begin_answer`, or None.

        Called from the display's telemetry loop: must not block."""
        return None

    def rewarm(self, seconds: float) -> None:
        """Inter-trial rewarming of the finger for ``seconds`` s (no wait on a virtual clock)."""
        if seconds > 0:
            self.show_text(f"Rewarm your finger on the hot-water bag ({seconds:.0f} s)")
            self.sleep(seconds)

    # -- helpers for subclasses ----------------------------------------------------------
    def log(self, kind: str, **fields) -> None:
        """Append an event to the session's log (no-op outside a session)."""
        if self.session is not None:
            self.session.log_event(kind, **fields)

    def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` s on the session's clock (returns at once on a virtual clock)."""
        if self.session is not None:
            self.session.clock.sleep(seconds)
        else:
            time.sleep(max(0.0, seconds))


def _capabilities(display) -> tuple:
    info = getattr(display, "info", None)
    return tuple(getattr(info, "capabilities", ()) or ())


def responder_names() -> list[str]:
    """Names :func:`get_responder` accepts."""
    return sorted(set(_KNOWN_MODULES) | set(_REGISTRY))


def get_responder(name: str, **options) -> Responder:
    """Make the responder registered as ``name``, importing its module on first use.

    Raises
    ------
    UserInputError
        Unknown name or option.
    """
    if name not in _REGISTRY and name in _KNOWN_MODULES:
        importlib.import_module(f"{__package__}.{_KNOWN_MODULES[name]}")
    cls = _REGISTRY.get(name)
    if cls is None:
        raise UserInputError(f"--responder: expected one of {responder_names()}, got {name!r}")
    try:
        inspect.signature(cls).bind(**options)
    except TypeError as exc:
        raise UserInputError(f"responder {name!r}: options {sorted(options)}: expected options "
                             f"of {cls.__name__}{inspect.signature(cls)}, got {exc}") from None
    return cls(**options)

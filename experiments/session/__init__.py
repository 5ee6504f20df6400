"""Sessions: one participant through one protocol, every step logged, nothing lost.

A session lives in ``DATA/<participant>/<session>/``:

``session.json``
    The protocol (data and hash), the participant record and group, the seed, the schedule,
    the display URL, the responder and the package versions. Written once (atomically).
``events.jsonl``
    The source of truth (:class:`sessionfiles.logbook.EventLog`, fsynced per event): every
    state change, upload, contact, response, completed or aborted trial.
``trials.csv``
    Rebuilt from the events (atomically) after every trial.
``traces/trial-NNN.csv``
    The telemetry of each trial, streamed while it runs.

Each trial is an explicit state machine (:data:`TRANSITIONS`)::

    idle -> prompt -> prepare -> cue -> wait_contact -> playback | record -> respond -> write
         -> rewarm -> idle ...                      \\-> no_contact (aborted, re-run)
    prepare | wait_contact | playback | record -> fault -> write

``prompt`` asks the experimenter to place the sample (real trials); ``prepare`` computes and
uploads the target profile and arms the display (playback for simulated trials, record for
real ones); ``cue`` plays the sound. A :class:`~experiments.errors.DisplayError` or a faulted
recording puts the display to neutral and writes the attempt with status ``"fault"`` (and its
``fault_code``); the trial is then run again as its next attempt, and after
``max_consecutive_faults`` faults or contact time-outs in a row the session stops cleanly
(resumable: the stopped trial is the first one run on resume). SIGINT and SIGTERM put the
display to neutral, log the running attempt as aborted and a ``session_interrupted`` event, and
:meth:`Session.run` returns 1. :func:`open_session` + :meth:`Session.run` resume: the first
incomplete trial is re-run with the next attempt number, completed trials are never re-run.

The package, one concept a module:

:mod:`~experiments.session.engine`
    :class:`Session`: the run, the session-level states, faults in a row, interruption.
:mod:`~experiments.session.trial`
    One method per state of a trial, in the order of :data:`TRANSITIONS`.
:mod:`~experiments.session.machine`
    The transition table, the state machine, the clocks.
:mod:`~experiments.session.making`
    :func:`plan_session`, :func:`create_session`, :func:`open_session`, :func:`finished_sessions`, :func:`unfinished_sessions`.
:mod:`~experiments.session.setup`
    What is checked and opened before anything is written (profiles, display).
:mod:`~experiments.session.store`
    ``session.json``: written, read back and checked.
:mod:`~experiments.session.planning`
    The simulated trials' profiles during a run and the scene planner's decisions.
:mod:`~experiments.session.traces`
    A trial's trace file: kept per attempt, never overwritten, read back.
:mod:`~experiments.session.trials_table`
    ``trials.csv`` rebuilt from ``events.jsonl`` after every trial (atomically; appended only
    with durability off).
:mod:`~experiments.session.signals`
    SIGINT/SIGTERM held while the session writes.
:mod:`~experiments.session.hooks`
    The pause points tests stop a session at.
"""
from __future__ import annotations

from experiments.session.engine import Session
from experiments.session.hooks import PAUSE_ENV, PAUSE_POINTS, PauseAt, SessionHooks
from experiments.session.machine import (
    TRANSITIONS,
    RealClock,
    SessionInterrupted,
    StateMachine,
    TransitionError,
    VirtualClock,
    clock_for_url,
)
from experiments.session.making import (
    SessionPlan,
    create_session,
    finished_sessions,
    unfinished_sessions,
    open_session,
    plan_session,
)
from experiments.session.setup import (
    check_schedule_profiles,
    open_session_display,
    simulated_target_profile,
)
from experiments.session.store import block_roles

__all__ = [
    "Session",
    "create_session",
    "plan_session",
    "SessionPlan",
    "simulated_target_profile",
    "check_schedule_profiles",
    "open_session_display",
    "open_session",
    "SessionInterrupted",
    "TransitionError",
    "StateMachine",
    "TRANSITIONS",
    "RealClock",
    "VirtualClock",
    "clock_for_url",
    "PAUSE_ENV",
    "PAUSE_POINTS",
    "SessionHooks",
    "PauseAt",
    "block_roles",
    "finished_sessions",
    "unfinished_sessions",
]

"""Tests of the session's state machine and clocks (experiments.session.machine)."""
from __future__ import annotations

import time

import pytest

from experiments.errors import UserInputError
from experiments.session.machine import (
    TRANSITIONS,
    RealClock,
    StateMachine,
    TransitionError,
    VirtualClock,
    clock_for_url,
)


def test_illegal_transition_names_both_states():
    seen = []
    sm = StateMachine(on_change=lambda old, new, **ctx: seen.append((old, new, ctx)))
    sm.go("prompt", trial_index=1)
    with pytest.raises(TransitionError, match=r"'prompt' -> 'respond'"):
        sm.go("respond")
    assert sm.state == "prompt" and seen == [("idle", "prompt", {"trial_index": 1})]


def test_transition_table_is_closed_and_reaches_the_end_states():
    for src, targets in TRANSITIONS.items():
        assert targets <= set(TRANSITIONS), src
    # The trial cycle of the docstring is legal, for both trial kinds.
    for active in ("playback", "record"):
        sm = StateMachine()
        for s in ("prompt", "prepare", "cue", "wait_contact", active, "respond", "write",
                  "rewarm", "idle", "finished"):
            sm.go(s)
    # Every non-final state can be interrupted.
    assert all("interrupted" in t for s, t in TRANSITIONS.items()
               if s not in ("finished", "stopped", "interrupted"))


def test_illegal_initial_state_is_refused():
    with pytest.raises(ValueError, match="initial"):
        StateMachine(initial="dancing")


def test_clock_follows_the_display_url_unless_told():
    assert clock_for_url("emulator://?clock=virtual&seed=1").virtual
    assert not clock_for_url("emulator://?seed=1").virtual
    assert not clock_for_url("/dev/ttyUSB0").virtual
    assert isinstance(clock_for_url("emulator://?clock=virtual", "real"), RealClock)
    assert isinstance(clock_for_url("/dev/pts/3", "virtual"), VirtualClock)
    with pytest.raises(UserInputError, match="--clock"):
        clock_for_url("/dev/pts/3", "sundial")


def test_virtual_clock_does_not_wait():
    c = VirtualClock()
    t0 = time.perf_counter()
    c.sleep(30.0)
    c.sleep(-1.0)
    assert c.now == 30.0 and time.perf_counter() - t0 < 0.1

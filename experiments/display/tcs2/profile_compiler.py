"""A target profile as the fewest linear segments a QST.Lab TCS II plays, with its error stated.

The TCS II plays a user profile (its ``Uw`` command) as up to 999 linear segments, each lasting
a whole number of 10 ms steps from 10 ms to 9.99 s and ending at a temperature in steps of
0.1 °C; the first segment starts where the probe is when stimulation starts. A simulated
material profile is 2,000 samples (20 s at 100 Hz) at 0.01 °C. :func:`compile_profile` finds
the fewest such segments whose largest deviation from the target is within a tolerance (by
default the device's 0.1 °C resolution), and refuses, in one line naming the profile and the
bound, what cannot be met.

The search is exact under the device's grids: a breakpoint lies on a sample whose time is a
multiple of 10 ms and holds a multiple of 0.1 °C, and a breadth-first search over such
breakpoints (each expanded once, its reach computed in one vectorised pass) returns a path with
the fewest segments. Between breakpoints both the target (linear between its samples) and the
segment are linear, so the deviation at the samples is the deviation at every instant.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from experiments.errors import SafetyLimitError, UserInputError

from ..safety import RESOLUTION_C as RATE_SLACK_C, SafetyLimits, check_profile, profile_max_rate

__all__ = ["Segment", "CompiledProfile", "compile_profile", "segments_to_samples",
           "STEP_S", "RESOLUTION_C", "MAX_SEGMENTS", "MAX_SEGMENT_STEPS"]

#: Time step of a segment's duration, s (the ``ddd`` field counts tens of ms).
STEP_S = 0.01
#: Temperature step of a segment's end, °C (the ``ttt`` field counts tenths of a degree).
RESOLUTION_C = 0.1
#: Most segments one ``Uw`` command carries (``nnn`` is three digits).
MAX_SEGMENTS = 999
#: Longest segment, in 10 ms steps (``ddd`` = 999: 9.99 s).
MAX_SEGMENT_STEPS = 999


@dataclass(frozen=True)
class Segment:
    """One linear piece: ``steps`` × 10 ms long, ending at ``end_dC`` tenths of a °C."""

    steps: int
    end_dC: int

    @property
    def duration_s(self) -> float:
        """Length, s."""
        return self.steps * STEP_S

    @property
    def end_C(self) -> float:
        """Temperature at the segment's end, °C."""
        return self.end_dC / 10.0


@dataclass(frozen=True)
class CompiledProfile:
    """The segments of a target profile and how far they stray from it.

    Parameters
    ----------
    start_C : float, °C
        Where the first segment starts (the probe's temperature when stimulation starts).
    segments : tuple of Segment
    max_deviation_C : float, °C
        Largest ``|played - target|`` over the target's samples (measured on the result).
    tolerance_C : float, °C
        The bound it was compiled to.
    """

    start_C: float
    segments: tuple
    max_deviation_C: float
    tolerance_C: float

    @property
    def count(self) -> int:
        """Number of segments."""
        return len(self.segments)

    @property
    def duration_s(self) -> float:
        """Total length, s."""
        return sum(s.steps for s in self.segments) * STEP_S


def segments_to_samples(start_C: float, segments, times_s) -> np.ndarray:
    """What the device plays at ``times_s`` (s, from the start of stimulation), °C."""
    knots_t = np.concatenate([[0.0], np.cumsum([s.steps for s in segments]) * STEP_S])
    knots_y = np.concatenate([[start_C], [s.end_C for s in segments]])
    return np.interp(np.asarray(times_s, dtype=float), knots_t, knots_y)


@dataclass(frozen=True)
class _Grid:
    """The search's ground: the target on its samples and the device's grids and bounds."""

    t: np.ndarray            # sample times from 0, s
    y: np.ndarray            # the target, °C
    tol: float               # largest allowed deviation, °C
    lo_q: int                # lowest segment end, 0.1 °C
    hi_q: int                # highest segment end, 0.1 °C
    rate: float              # rate limit, °C/s
    window: float            # the rate limit's window, s
    every: int               # breakpoints on every `every`-th sample (the 10 ms grid)
    max_reach: int           # the longest segment, in samples


def _grid_step(dt: float, n: int, name: str) -> int:
    """Every how many samples a breakpoint may lie (the 10 ms grid); UserInputError for a step
    that neither divides 10 ms nor is a multiple of it, or a duration off the grid."""
    ratio = STEP_S / dt
    if abs(ratio - round(ratio)) < 1e-6 and round(ratio) >= 1:
        every = int(round(ratio))                 # breakpoints on every `every`-th sample
    elif abs(dt / STEP_S - round(dt / STEP_S)) < 1e-6:
        every = 1                                 # a step of 20 ms, 50 ms, ...: every sample
    else:
        raise UserInputError(f"{name}: times_s: expected a step that divides 10 ms or is a "
                             f"multiple of it (the device's segment grid), got {dt * 1e3:.6g} ms")
    if (n - 1) % every:
        raise UserInputError(f"{name}: times_s: expected a duration that is a multiple of 10 ms, "
                             f"got {(n - 1) * dt:.6g} s")
    return every


def _start_q(y0: float, start_C, g: _Grid, min_C: float, hi_C: float, name: str) -> int:
    """The first segment's start, 0.1 °C: ``start_C`` or the first sample rounded, checked."""
    if start_C is None:
        s0 = int(round(y0 * 10))
    else:
        s0 = int(round(float(start_C) * 10))
        if abs(s0 / 10 - float(start_C)) > 1e-9:
            raise UserInputError(f"{name}: start_C: expected a multiple of 0.1 °C, got {start_C!r}")
    if not g.lo_q <= s0 <= g.hi_q:
        raise SafetyLimitError(f"{name}: start_C: expected {min_C} ≤ T ≤ {hi_C} °C, "
                               f"got {s0 / 10}")
    if abs(s0 / 10 - y0) > g.tol + 1e-12:
        raise UserInputError(f"{name}: expected a first sample within {g.tol:g} °C of the start "
                             f"{s0 / 10:g} °C, got {y0:.4g} °C")
    return s0


def _reach(g: _Grid, i: int, u: int):
    """The breakpoints one segment from breakpoint ``(i, u)`` reaches within the tolerance and
    the rate limit: their samples and ends (0.1 °C), or None."""
    eps = 1e-9
    t, y, tol, rate = g.t, g.y, g.tol, g.rate
    j_end = min(y.size - 1, i + g.max_reach)
    if j_end <= i:
        return None
    k = np.arange(i + 1, j_end + 1)
    span = t[k] - t[i]
    base = u / 10.0
    # slopes that keep every sample from i+1 to j within the tolerance (prefix intersection)
    m_lo = np.maximum.accumulate((y[k] - tol - base) / span)
    m_hi = np.minimum.accumulate((y[k] + tol - base) / span)
    # the rate limit holds over the protocol's window: a segment at least that long
    # is no steeper than the limit; shorter ones are checked on the result below
    long = span >= g.window - 1e-9
    m_lo = np.where(long, np.maximum(m_lo, -rate), m_lo)
    m_hi = np.where(long, np.minimum(m_hi, rate), m_hi)
    ok = m_lo <= m_hi + eps
    if not ok.all():
        last = int(np.argmin(ok))         # the first infeasible end: none beyond it
        k, span, m_lo, m_hi = k[:last], span[:last], m_lo[:last], m_hi[:last]
    grid = k % g.every == 0               # ends on the 10 ms grid only
    k, span, m_lo, m_hi = k[grid], span[grid], m_lo[grid], m_hi[grid]
    if k.size == 0:
        return None
    q_lo = np.maximum(np.ceil((base + m_lo * span) * 10 - 1e-6).astype(np.int64), g.lo_q)
    q_hi = np.minimum(np.floor((base + m_hi * span) * 10 + 1e-6).astype(np.int64), g.hi_q)
    count = np.maximum(q_hi - q_lo + 1, 0)
    total = int(count.sum())
    if total == 0:
        return None
    jj = np.repeat(k, count)
    first = np.repeat(np.cumsum(count) - count, count)
    return jj, np.repeat(q_lo, count) + (np.arange(total) - first)


def _search(g: _Grid, s0: int, max_segments: int):
    """Breadth-first search: layer k holds the breakpoints (sample j, end q in 0.1 °C) reachable
    with k segments; each is claimed by the first breakpoint of the layer before that reaches
    it. Returns the goal (None if none), the layers searched, where each breakpoint came from
    (``from_j``, ``from_q``) and which were seen."""
    n, y, lo_q = g.y.size, g.y, g.lo_q
    nq = g.hi_q - lo_q + 1
    seen = np.zeros((n, nq), dtype=bool)
    from_j = np.full((n, nq), -1, dtype=np.int64)
    from_q = np.zeros((n, nq), dtype=np.int64)
    seen[0, s0 - lo_q] = True
    layer = [(0, s0)]
    goal = None
    depth = 0
    while layer and goal is None and depth < max_segments:
        depth += 1
        nxt_j, nxt_q = [], []
        for i, u in layer:
            reached = _reach(g, i, u)
            if reached is None:
                continue
            jj, qq = reached
            new = ~seen[jj, qq - lo_q]
            jj, qq = jj[new], qq[new]
            if jj.size == 0:
                continue
            seen[jj, qq - lo_q] = True
            from_j[jj, qq - lo_q] = i
            from_q[jj, qq - lo_q] = u
            at_end = jj == n - 1
            if at_end.any():                      # the last sample: the end nearest the target
                qs = qq[at_end]
                goal = (n - 1, int(qs[np.argmin(np.abs(qs - y[-1] * 10))]))
                break
            nxt_j.append(jj)
            nxt_q.append(qq)
        if goal is None and nxt_j:
            jj, qq = np.concatenate(nxt_j), np.concatenate(nxt_q)
            # farthest first, then nearest the target: of the paths with the fewest segments
            # the search keeps the one it reaches first, so this favours the closer ones
            order = np.lexsort((np.abs(qq - y[jj] * 10), -jj))
            layer = list(zip(jj[order].tolist(), qq[order].tolist()))
        else:
            layer = []
    return goal, depth, from_j, from_q, seen


def _segments(g: _Grid, goal, from_j, from_q) -> tuple:
    """The segments of the path that ends at ``goal``, first to last."""
    path = []
    j, q = goal
    while j != 0:
        pj, pq = int(from_j[j, q - g.lo_q]), int(from_q[j, q - g.lo_q])
        path.append(Segment(steps=int(round((g.t[j] - g.t[pj]) / STEP_S)), end_dC=int(q)))
        j, q = pj, pq
    return tuple(reversed(path))


def compile_profile(times_s, target_C, *, tolerance_C: float = RESOLUTION_C,
                    limits: SafetyLimits | None = None, start_C: float | None = None,
                    max_C: float | None = None, max_segments: int = MAX_SEGMENTS,
                    name: str = "profile") -> CompiledProfile:
    """The fewest TCS II segments within ``tolerance_C`` of a uniformly sampled target.

    Parameters
    ----------
    times_s : array_like, s
        Uniform sample times from 0; the step must divide 10 ms or be a multiple of it.
    target_C : array_like, °C
    tolerance_C : float, °C
        Largest allowed ``|played - target|`` (default the device's 0.1 °C resolution).
    limits : SafetyLimits, optional
        The protocol's safe range and rate limit: the target is checked against them first
        (:func:`experiments.display.safety.check_profile`), every segment end lies in the
        range and no segment is steeper than the rate limit.
    start_C : float, °C, optional
        Where the probe is at the start (default: the first sample rounded to 0.1 °C).
    max_C : float, °C, optional
        The device's maximum stimulation temperature (``Om``); segment ends stay at or below.
    max_segments : int
        The device's capacity (999).
    name : str
        How a refusal names the profile.

    Returns
    -------
    CompiledProfile

    Raises
    ------
    SafetyLimitError
        The target leaves the safe range or is faster than the rate limit.
    UserInputError
        Malformed times, or no segments within the bounds (one line: the profile and the
        bound that cannot be met).
    """
    limits = limits or SafetyLimits()
    dt, y = check_profile(times_s, target_C, limits)
    tol = float(tolerance_C)
    if not (math.isfinite(tol) and tol > 0):
        raise UserInputError(f"{name}: tolerance_C: expected a positive number, got {tolerance_C!r}")
    every = _grid_step(dt, y.size, name)
    hi_C = limits.max_C if max_C is None else min(limits.max_C, float(max_C))
    g = _Grid(t=np.arange(y.size) * dt, y=y, tol=tol, lo_q=math.ceil(limits.min_C * 10 - 1e-9),
              hi_q=math.floor(hi_C * 10 + 1e-9), rate=limits.max_rate_C_per_s,
              window=limits.rate_window_s, every=every,
              max_reach=(MAX_SEGMENT_STEPS * every if every > 1
                         else int(round(MAX_SEGMENT_STEPS * STEP_S / dt))))
    s0 = _start_q(y[0], start_C, g, limits.min_C, hi_C, name)
    goal, depth, from_j, from_q, seen = _search(g, s0, max_segments)
    if goal is None:
        reached = int(np.max(np.nonzero(seen.any(axis=1))[0])) * dt
        why = (f"more than {max_segments} segments" if depth >= max_segments
               else f"a breakpoint nearer than 0.1 °C steps allow after {reached:.2f} s")
        raise UserInputError(
            f"{name}: expected a profile the TCS II can play within {tol:g} °C (segments of "
            f"10 ms–9.99 s, ends at 0.1 °C, {limits.min_C:g}–{hi_C:g} °C), "
            f"got one that needs {why}")
    segments = _segments(g, goal, from_j, from_q)
    played = segments_to_samples(s0 / 10, segments, g.t)
    fast = profile_max_rate(played, dt, g.window)
    if fast > g.rate * (1 + 1e-9) + RATE_SLACK_C / g.window:
        raise UserInputError(
            f"{name}: expected segments within {tol:g} °C no faster than {g.rate:g} °C/s over "
            f"{g.window:g} s, got {fast:.3g} °C/s (a tighter tolerance_C or a slower target)")
    return CompiledProfile(start_C=s0 / 10, segments=segments,
                           max_deviation_C=float(np.max(np.abs(played - y))), tolerance_C=tol)

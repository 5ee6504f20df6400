"""A trial's trace file and what it says: never overwritten, kept per attempt, read back.

``traces/trial-NNN.csv`` is streamed by :class:`sessionfiles.session_files.TraceWriter` while
the trial runs. An attempt that does not complete keeps its trace under an ``aborted`` or
``fault`` name (:func:`keep_trace`) so the next attempt starts a fresh file; a trace that is
there before its attempt starts is moved aside, never overwritten (:func:`keep_aside`). The
written trace gives the contact force (:func:`contact_force`) and what the responder is
given to answer from (:func:`trial_stimulus`).
"""
from __future__ import annotations

import os
from pathlib import Path

from experiments.responders.base import TrialStimulus
from sessionfiles.session_files import aborted_trace_name, trace_name

__all__ = ["keep_trace", "keep_aside", "unused_name", "contact_force", "trial_stimulus"]


def keep_trace(traces_dir: Path, trial_index: int, attempt: int, kind: str, *,
               durable: bool = True):
    """Move an unfinished attempt's trace out of the way of the next attempt.

    Returns the kept file (also when a kill came between this rename and the event that
    records it), or None if the attempt never started its trace.
    """
    from sessionfiles.logbook import fsync_dir
    trace = traces_dir / trace_name(trial_index)
    if trace.exists():
        kept = traces_dir / aborted_trace_name(trial_index, attempt, kind)
        os.replace(trace, kept)
        fsync_dir(traces_dir, durable)
        return kept
    earlier = sorted(traces_dir.glob(aborted_trace_name(trial_index, attempt, "*")))
    return earlier[0] if earlier else None


def keep_aside(trace: Path, attempt: int) -> Path:
    """Move a trace found before ``attempt`` started to an unused ``replaced-before`` name."""
    aside = unused_name(trace.with_name(f"{trace.stem}.replaced-before-attempt-{attempt}.csv"))
    os.replace(trace, aside)
    return aside


def unused_name(path: Path) -> Path:
    """``path``, or ``path`` with ``.2``, ``.3``, ... before the suffix: a name not taken."""
    n, out = 1, path
    while out.exists():
        n += 1
        out = path.with_name(f"{path.stem}.{n}{path.suffix}")
    return out


def contact_force(writer, rec) -> float | None:
    """Mean summed force the display's four sensors measured over the contact, N."""
    if rec.contact_time_s is None or not writer.frames:
        return None
    from experiments.responders.base import contact_force as mean_force
    time_s, _, _, forces_N = writer.arrays()
    value = mean_force(time_s - float(rec.contact_time_s), forces_N)
    return None if value is None else round(value, 2)


def trial_stimulus(protocol, spec, writer, rec, profile, sample) -> TrialStimulus:
    """What the responder answers from: the trace (time from contact), the profile, the sample."""
    t, target_C, contact_C, forces = writer.arrays()
    t = t - float(rec.contact_time_s) if rec.contact_time_s is not None and t.size else t.copy()
    forces = forces.copy()
    material = protocol.material
    sample_info = None
    if spec.mode != "simulated":
        sample_info = {"label": sample.label, "material": material.name,
                       "roughness_m": sample.roughness_m, "thickness_m": material.thickness_m,
                       "temperature_C": protocol.environment.room_temperature_C}
    return TrialStimulus(mode=spec.mode, roughness_id=spec.roughness_id,
                         roughness_um=spec.roughness_um, time_s=t,
                         target_C=target_C.copy(), contact_C=contact_C.copy(), forces_N=forces,
                         profile_parameters=None if profile is None else dict(profile.parameters),
                         sample=sample_info, status=rec.status)

"""The tasks ``reproduce figure9`` runs on its cluster's workers, kept light to import.

A worker imports the module of every task function it runs.  These need NumPy and the
participant model only: no pandas, pyarrow or :mod:`analysis` (whose package imports SciPy's
statistics, pandas and the models): with them a worker was ~65 MiB larger (RSS after a pool
and a batch of studies: 201 against 136 MiB) and spent ~1 s more CPU importing.  What does need :mod:`analysis` -- a study's claims
(:func:`analysis.claims.evaluate_readings`) -- runs in the main process on each task's result
as it arrives (:func:`claims_of_studies`, the ``then`` of :meth:`..sweep.Sweep.map`): the same
function on the same arrays, so the same numbers.
"""
from __future__ import annotations

import numpy as np

__all__ = ["study_task", "claims_of_studies", "build_pool_task", "group_pool_task",
           "depth_grid_task"]


def _compact(counts: np.ndarray) -> np.ndarray:
    """Small non-negative counts as int8 for the trip to the main process (int64 otherwise)."""
    counts = np.asarray(counts)
    if counts.size and 0 <= counts.min() and counts.max() <= np.iinfo(np.int8).max:
        return counts.astype(np.int8)
    return counts


def study_task(pool, hypothesis: str, observer: str, n_studies: int, n_per_group: int,
               familiarise_reps: int, params, seed, temps, variability=None) -> dict:
    """One task of a sweep: ``n_studies`` studies of one scenario, reduced to what tables need.

    Returns
    -------
    dict
        ``correct`` (S, P, 2 modes, C) and ``answered`` (S, P, 2, C: answers given per class),
        compact; ``groups``, ``repetitions``, ``temps`` (for the claims,
        :func:`claims_of_studies`); ``proportions``: per-study proportion correct, shape
        (S, groups, 2 modes, C); ``answer_share``: the simulated block's answers per class (S, C).
    """
    from experiments.participant_model.observers import get_observer
    from experiments.simulation.studies import GROUPS, simulate_studies
    out = simulate_studies(pool, hypothesis, get_observer(observer), n_studies=n_studies,
                           n_per_group=n_per_group, familiarise_reps=familiarise_reps,
                           params=params, seed=seed, variability=variability)
    answered = out.answers.sum(axis=-2)                            # (S, P, 2, C)
    props = np.stack([out.correct[:, out.groups == g].mean(axis=1) / out.repetitions
                      for g in GROUPS], axis=1)
    pooled = answered[:, :, 1].sum(axis=1).astype(float)           # (S, C) simulated block
    with np.errstate(divide="ignore", invalid="ignore"):
        share = pooled / pooled.sum(axis=1, keepdims=True)
    return {"correct": _compact(out.correct), "answered": _compact(answered),
            "groups": out.groups, "repetitions": out.repetitions, "temps": temps,
            "proportions": props, "answer_share": share}


def claims_of_studies(raw: dict) -> dict:
    """A :func:`study_task` result with its claims: ``readings``
    (:func:`analysis.claims.evaluate_readings` of the studies), ``proportions``,
    ``answer_share`` (in the main process: the workers never import :mod:`analysis`)."""
    from analysis.claims import evaluate_readings
    readings = evaluate_readings(raw["correct"].astype(np.int64), raw["groups"],
                                 raw["repetitions"], raw["temps"],
                                 answered=raw["answered"].astype(np.int64))
    return {"readings": readings, "proportions": raw["proportions"],
            "answer_share": raw["answer_share"]}


def build_pool_task(protocol, kwargs):
    """:func:`..studies.build_pool` as a sweep task (``replay_skin_C``: the protocol's
    ``[simulation] skin_temperature_C`` changed to it, i.e. the replays computed for that skin)."""
    from experiments.simulation.studies import build_pool
    kwargs = dict(kwargs)
    skin_C = kwargs.pop("replay_skin_C", None)
    if skin_C is not None:
        from experiments.protocol import load_protocol, parse_protocol
        from experiments.simulation.replay import _with_simulation
        base = protocol if hasattr(protocol, "data") else load_protocol(protocol)
        protocol = parse_protocol(_with_simulation(base.data, skin_temperature_C=float(skin_C)),
                                  source=f"{base.name} (replays for {skin_C:g} °C skin)", path=None)
    return build_pool(protocol, **kwargs)


def group_pool_task(group, hypotheses, seed):
    """The person pool of one group (a sweep task)."""
    from experiments.simulation.studies import build_pool
    return build_pool(hypotheses=hypotheses, seed=seed, groups=(group,))


def depth_grid_task(protocol, kwargs, depth_share, noises, n_studies, seed):
    """One depth share of the receptor-depth fit's grid (a sweep task): its person pool
    (:func:`build_pool_task`) and the answer probabilities at each noise
    (:func:`..depth_fit.answer_grid`, which need no study: computed here beside the sessions,
    the fit to the study's counts is then only likelihoods).  ``(pool, probabilities)``."""
    from experiments.simulation.depth_fit import answer_grid
    pool = build_pool_task(protocol, kwargs)
    return pool, answer_grid(depth_share, noises, n_studies=n_studies, seed=seed, pool=pool)

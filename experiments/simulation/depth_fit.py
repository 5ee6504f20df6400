"""The receptor depth (and the observer's noise) estimated from a study's real-block answers.

The real samples' physics is known (Eq. 5 contact, the exact slab solution); what is not is where
the cold receptors lie below the surface and how noisy the participant's percept is.  For each
(depth share, noise) of a grid, many simulated studies give the probability of every answer to
every real sample per group (the absolute observer, the default lab); the study's real-block
confusion counts then have a multinomial log-likelihood.  Its profile over the depth (maximised
over the noise) gives the estimate and a likelihood-ratio interval (the depths within 1.92 of the
maximum: 95 % for one parameter), and shows whether the depth is identifiable at all (a flat
profile: it is not).  Trials of one participant are treated as independent given the cell, so the
interval is narrower than a model with participant effects would give.

Depth share: the receptors' depth below the surface as a share of the skin thickness L
(1 - d / L); the participant model's default is 0.35-0.45.

The grid's answer probabilities need no study (:func:`answer_grid`, one depth share's row of the
grid): ``reproduce figure9`` computes them on its cluster's workers beside the sessions, and the
fit to a study's counts is then only the likelihoods.  pandas is imported only where a table is
made, so that a worker running :func:`answer_grid` does not import it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["DEPTH_SHARES", "NOISES_C", "answer_probabilities", "answer_grid",
           "confusion_from_trials", "depth_pool_jobs", "fit_depth", "DepthFit"]

#: Depth shares of the grid (receptor depth / L).
DEPTH_SHARES = (0.25, 0.30, 0.35, 0.40, 0.45, 0.50, 0.55)
#: Noise floors of the grid, K (and K/s on the rate), as :class:`PerceptionParameters` reads them.
NOISES_C = (0.15, 0.3, 0.45, 0.6)
#: Half the 95 % point of chi-square with one degree of freedom.
LR_HALF_95 = 1.9207


def answer_probabilities(depth_share: float, noise_C: float, *, n_studies: int = 40,
                         seed: int = 0, pool=None, observer: str = "absolute") -> np.ndarray:
    """P(answer | sample, group) in the real block, shape (2 groups, C, C), by simulation."""
    import dataclasses

    from experiments.participant_model.observers import get_observer
    from experiments.simulation.studies import build_pool, simulate_studies
    frac = 1.0 - float(depth_share)
    pool = pool or build_pool(hypotheses=("slab",), dermis_fraction=(frac, frac), seed=seed)
    params = dataclasses.replace(pool.params, drop_noise_C=noise_C, rate_noise_C_per_s=noise_C)
    out = simulate_studies(pool, "slab", get_observer(observer), n_studies=n_studies,
                           params=params, seed=(int(seed), 0xDE7))
    counts = np.stack([out.answers[:, out.groups == g, 0].sum(axis=(0, 1)) for g in ("A", "B")])
    counts = counts + 0.5                                   # no impossible answer
    return counts / counts.sum(axis=-1, keepdims=True)


def answer_grid(depth_share: float, noises=NOISES_C, *, n_studies: int = 40, seed: int = 0,
                pool=None) -> np.ndarray:
    """:func:`answer_probabilities` of one depth share at each noise of ``noises``, shape
    (noises, 2 groups, C, C): one depth's part of :func:`fit_depth`'s grid, with the same
    arguments (so the same numbers wherever it runs)."""
    return np.stack([answer_probabilities(depth_share, n, n_studies=n_studies, seed=seed,
                                          pool=pool) for n in noises])


def confusion_from_trials(trials: pd.DataFrame, mode: str = "real", roughness_ids=(1, 2, 3, 4)):
    """Answer counts (2 groups A, B; sample; answer) of one study's ``mode`` trials."""
    out = np.zeros((2, len(roughness_ids), len(roughness_ids)))
    sel = trials[(trials["mode"] == mode)].dropna(subset=["response_id"])
    for gi, g in enumerate(("A", "B")):
        for i, r in enumerate(roughness_ids):
            for j, a in enumerate(roughness_ids):
                out[gi, i, j] = int(((sel["group"] == g) & (sel["roughness_id"] == r)
                                     & (sel["response_id"].astype(int) == a)).sum())
    return out


@dataclass
class DepthFit:
    """The grid's log-likelihoods and the depth's profile.

    Attributes
    ----------
    grid : pandas.DataFrame
        depth_share, noise_C, loglik.
    profile : pandas.Series
        Depth share -> log-likelihood maximised over the noise.
    estimate : float
    interval : (float, float)
        Depth shares within :data:`LR_HALF_95` of the maximum (grid resolution).
    noise_C : float
        The noise at the maximum.
    """

    grid: pd.DataFrame
    profile: pd.Series
    estimate: float
    interval: tuple
    noise_C: float

    def identifiable(self) -> bool:
        """Whether the interval excludes some of the grid's depths."""
        return not (self.interval[0] == self.profile.index.min()
                    and self.interval[1] == self.profile.index.max())


def depth_pool_jobs(depth_shares=DEPTH_SHARES, seed: int = 0, also=()) -> list:
    """``(protocol, build_pool keyword arguments)`` of the pool of each depth share
    (:func:`experiments.simulation.figure9.tasks.build_pool_task`'s arguments: a sweep
    builds them side by side).

    ``also``: replay hypotheses the pools hold besides the fit's ``slab`` (the fit reads only
    ``slab``'s; ``reproduce figure9`` reuses a pool for its headline at the fitted depth).
    """
    hypotheses = ("slab",) + tuple(h for h in also if h != "slab")
    return [("roughness_recognition", {"hypotheses": hypotheses, "seed": seed,
                                       "dermis_fraction": (1.0 - float(d), 1.0 - float(d))})
            for d in depth_shares]


def fit_depth(counts, depth_shares=DEPTH_SHARES, noises=NOISES_C, *, n_studies: int = 40,
              seed: int = 0, pools: list | None = None,
              probabilities: list | None = None) -> DepthFit:
    """Profile likelihood of the receptor depth from real-block answer counts (2, C, C).

    ``pools``: the person pools of :func:`depth_pool_jobs` (same order), already built;
    default: built here, one after the other.  ``probabilities``: the grid's answer
    probabilities already computed, :func:`answer_grid` of each depth share (same order, with
    these ``noises``, ``n_studies`` and ``seed``); then no pool is needed.
    """
    import pandas as pd
    counts = np.asarray(counts, dtype=float)
    tasks = [(d, n) for d in depth_shares for n in noises]
    if probabilities is not None:
        probs = [p for grid in probabilities for p in grid]
        if len(probs) != len(tasks):
            raise ValueError(f"probabilities: expected {len(depth_shares)} depth shares x "
                             f"{len(noises)} noises, got {len(probs)} grids")
    else:
        if pools is None:
            from experiments.simulation.studies import build_pool
            pools = [build_pool(protocol, **kw)
                     for protocol, kw in depth_pool_jobs(depth_shares, seed)]
        probs = [p for d, pool in zip(depth_shares, pools)
                 for p in answer_grid(d, noises, n_studies=n_studies, seed=seed, pool=pool)]
    rows = [{"depth_share": d, "noise_C": n, "loglik": float(np.sum(counts * np.log(p)))}
            for (d, n), p in zip(tasks, probs)]
    grid = pd.DataFrame(rows)
    profile = grid.groupby("depth_share")["loglik"].max()
    best = grid.loc[grid["loglik"].idxmax()]
    inside = profile.index[profile >= profile.max() - LR_HALF_95]
    return DepthFit(grid=grid, profile=profile, estimate=float(best["depth_share"]),
                    interval=(float(inside.min()), float(inside.max())),
                    noise_C=float(best["noise_C"]))

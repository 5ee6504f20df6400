"""``reproduce figure9``'s receptor-depth rows: the fit's grid on the cluster, the fit to the
emulated study's real block, the headline at the fitted depth and its interval's ends.

:func:`.reproduction.run_reproduction` computes the grid (:func:`depth_grid`) beside the
sessions and fits it (:func:`fitted_depth_row`) as soon as they end, while it analyses them.
"""
from __future__ import annotations

import pandas as pd

from .report import depth_text

__all__ = ["DEPTH_GRID_STUDIES", "depth_grid", "fitted_depth_row", "with_depth_row", "depth_pools"]

#: Simulated studies per (depth share, noise) of the depth fit's grid.
DEPTH_GRID_STUDIES = 20


def depth_grid(seed, headline, sweep) -> tuple:
    """The depth fit's grid (:func:`..depth_fit.depth_pool_jobs`, the headline's replay too):
    ``(pools, answer probabilities)`` per depth share, as tasks of ``sweep``'s workers
    (:func:`.tasks.depth_grid_task`; in this process without ``sweep``)."""
    from experiments.simulation.depth_fit import DEPTH_SHARES, NOISES_C, depth_pool_jobs
    from experiments.simulation.figure9.tasks import depth_grid_task
    jobs = [(protocol, kw, share, NOISES_C, DEPTH_GRID_STUDIES, seed) for share, (protocol, kw)
            in zip(DEPTH_SHARES, depth_pool_jobs(DEPTH_SHARES, seed=seed, also=headline[:1]))]
    done = (sweep.map(depth_grid_task, jobs, what="depth grid pools") if sweep is not None
            else [depth_grid_task(*job) for job in jobs])
    return [pool for pool, _ in done], [probs for _, probs in done]


def with_depth_row(sens, depth):
    """The sensitivity table with the fitted depth's rows (``sens`` itself without a fit)."""
    from experiments.simulation.figure9.scenarios import SENSITIVITY_CHOICES, mark_differences
    if depth is None:
        return sens
    runs = sens.attrs["runs"] + depth["row"].attrs["runs"]
    sens = mark_differences(pd.concat([sens, depth["row"]], ignore_index=True),
                            SENSITIVITY_CHOICES)
    sens.attrs["runs"] = runs
    return sens


def fitted_depth_row(trials, pool, headline, n_studies, seed, sweep, lab, max_studies=None,
                      grid=None):
    """Fit the receptor depth to the emulated study's real block (``trials``: its analysable
    trials); the headline at that depth.

    ``grid``: the fit's grid (:func:`depth_grid`), already computed; default: computed now
    (on ``sweep``'s workers when given).
    Returns None without a study with both groups; else ``row`` (a sensitivity row),
    ``record`` (estimate, interval, noise, the profile) and ``text`` (a report paragraph).
    """
    from experiments.simulation.depth_fit import confusion_from_trials, fit_depth
    from experiments.simulation.figure9.scenarios import sensitivity
    if trials is None or trials.empty or trials["group"].nunique() < 2:
        return None
    counts = confusion_from_trials(trials, "real")
    grid_pools, probabilities = grid if grid is not None else depth_grid(seed, headline, sweep)
    fit = fit_depth(counts, n_studies=DEPTH_GRID_STUDIES, seed=seed, pools=grid_pools,
                    probabilities=probabilities)
    # the estimate and the ends of its interval: the claims' probabilities across the depths
    # the study's answers allow (their best noise each)
    settings, jobs = {}, []
    for what, share in (("fitted", fit.estimate), ("interval low end", fit.interval[0]),
                        ("interval high end", fit.interval[1])):
        if any(abs(share - v[2]) < 1e-9 for v in settings.values()):
            continue
        frac = 1.0 - share
        noise = float(fit.grid.loc[fit.grid.depth_share == share].sort_values("loglik")
                      ["noise_C"].iloc[-1])
        jobs.append(("roughness_recognition", {"hypotheses": (headline[0],),
                                               "dermis_fraction": (frac, frac),
                                               "seed": pool.settings["seed"],
                                               "params": pool.params}))
        label = (f"depth share {share:.2f} of L, noise {noise:g} ({what}; 95 % LR "
                 f"{fit.interval[0]:.2f}-{fit.interval[1]:.2f})")
        settings[label] = ({"noise": noise}, what, share)
    for (change, *_), depth_pool in zip(settings.values(), depth_pools(jobs, grid_pools, sweep)):
        change["pool"] = depth_pool
    row = sensitivity(pool, *headline, n_studies=n_studies, seed=seed, sweep=sweep,
                      variability=lab, max_studies=max_studies,
                      choices={"receptor depth (fitted)": {k: v[0] for k, v in settings.items()}})
    record = {"estimate_share_of_L": fit.estimate, "interval_share_of_L": list(fit.interval),
              "noise_C": fit.noise_C, "identifiable": fit.identifiable(),
              "profile": {f"{d:.2f}": float(v) for d, v in fit.profile.items()}}
    return {"row": row, "record": record, "text": depth_text(record)}


def depth_pools(jobs, grid_pools, sweep) -> list:
    """The person pools of ``jobs`` (:func:`.tasks.build_pool_task`'s arguments): a grid pool
    of the depth fit where one is the same pool (the same seed, so the same persons; d / L,
    perception parameters and protocol, the job's hypotheses among its own: their features do
    not depend on the others), else built side by side on ``sweep``'s workers."""
    from experiments.simulation.figure9.tasks import build_pool_task
    out, missing = [], []
    for protocol, kw in jobs:
        same = [g for g in grid_pools or ()
                if protocol == "roughness_recognition" and set(kw) == {
                    "hypotheses", "dermis_fraction", "seed", "params"}
                and set(kw["hypotheses"]) <= set(g.hypotheses)
                and g.settings["seed"] == kw["seed"]
                and tuple(g.settings["dermis_fraction"]) == tuple(kw["dermis_fraction"])
                and g.params == kw["params"] and g.receptor_depth_um is None
                and not g.settings["sensor_tau_s"]]
        out.append(same[0] if same else None)
        if not same:
            missing.append((protocol, kw))
    built = iter(sweep.map(build_pool_task, missing, what="person pools") if sweep is not None
                 else [build_pool_task(*job) for job in missing])
    return [p if p is not None else next(built) for p in out]

"""The receptor depth recovered, with an interval, from simulated real-block answers."""
import numpy as np

from experiments.simulation.depth_fit import answer_probabilities, fit_depth


def test_depth_is_recovered_from_a_large_studys_real_block():
    # data: 20 studies' worth of real-block answers (300 persons per group) at depth share 0.40,
    # noise 0.3, drawn with another seed than the fit's predictions
    p = answer_probabilities(0.40, 0.3, n_studies=20, seed=11)
    counts = np.random.default_rng(3).multinomial(3 * 300, p.reshape(-1, 4) / p.reshape(-1, 4).sum(1, keepdims=True))
    counts = counts.reshape(2, 4, 4)
    fit = fit_depth(counts, depth_shares=(0.25, 0.40, 0.55), noises=(0.3, 0.6), n_studies=40)
    assert fit.estimate == 0.40 and fit.noise_C == 0.3
    assert fit.interval[0] <= 0.40 <= fit.interval[1]
    assert fit.identifiable()                      # 0.25 and 0.55 are excluded by the data
    assert fit.profile.idxmax() == 0.40 and len(fit.grid) == 6


def test_grid_built_as_sweep_tasks_gives_the_same_fit():
    # reproduce figure9 builds the grid's pools and their answer probabilities on the cluster's
    # workers before the study's answers exist (depth_grid_task of depth_pool_jobs) and passes
    # them in: the same likelihoods, bit for bit, as building and simulating everything here
    # after the study; pools alone given (the probabilities simulated here) too
    import pytest

    from experiments.simulation.depth_fit import depth_pool_jobs
    from experiments.simulation.figure9.tasks import depth_grid_task
    counts = np.arange(32, dtype=float).reshape(2, 4, 4) % 7
    shares, noises = (0.30, 0.50), (0.3, 0.6)
    here = fit_depth(counts, depth_shares=shares, noises=noises, n_studies=5, seed=2)
    done = [depth_grid_task(*job, share, noises, 5, 2)
            for share, job in zip(shares, depth_pool_jobs(shares, seed=2))]
    pools, probs = [p for p, _ in done], [g for _, g in done]
    assert [p.grid_fraction.tolist() for p in pools] == [[0.70], [0.50]]
    assert [g.shape for g in probs] == [(2, 2, 4, 4)] * 2
    with_pools = fit_depth(counts, depth_shares=shares, noises=noises, n_studies=5, seed=2,
                           pools=pools)
    with_probs = fit_depth(counts, depth_shares=shares, noises=noises, n_studies=5, seed=2,
                           probabilities=probs)
    for given in (with_pools, with_probs):
        assert here.grid["loglik"].tolist() == given.grid["loglik"].tolist()
        assert (here.estimate, here.interval, here.noise_C) == (given.estimate, given.interval,
                                                                given.noise_C)
    assert len(set(here.grid["loglik"])) == 4           # the grid's cells differ: a real check
    with pytest.raises(ValueError, match="probabilities: expected 2 depth shares x 2 noises"):
        fit_depth(counts, depth_shares=shares, noises=noises, probabilities=probs[:1])


def test_the_headlines_fitted_depth_reuses_the_grid_pool_which_is_the_same_pool():
    # reproduce figure9 builds the grid's pools with the headline's replay too (depth_pool_jobs'
    # ``also``) and uses the one at the fitted depth for the headline's row instead of building
    # it again: its real and replayed features are those of a pool built for the headline alone,
    # bit for bit; a depth, parameters or seed of no grid pool is built
    import dataclasses

    from experiments.simulation.depth_fit import depth_pool_jobs
    from experiments.simulation.figure9.fitted_depth import depth_pools
    from experiments.simulation.figure9.tasks import build_pool_task
    (job,) = depth_pool_jobs((0.40,), seed=2, also=("skin", "slab"))
    assert job[1]["hypotheses"] == ("slab", "skin")
    (grid,) = [build_pool_task(*job)]
    own = {"hypotheses": ("skin",), "dermis_fraction": (0.60, 0.60), "seed": 2,
           "params": grid.params}
    other = dict(own, params=dataclasses.replace(grid.params, drop_noise_C=0.6))
    reseeded = dict(own, seed=3)
    reused, built, built_seed = depth_pools([("roughness_recognition", own),
                                              ("roughness_recognition", other),
                                              ("roughness_recognition", reseeded)],
                                             [grid], sweep=None)
    alone = build_pool_task("roughness_recognition", own)
    assert reused is grid and built is not grid and built.params == other["params"]
    assert built_seed is not grid and built_seed.settings["seed"] == 3
    for g in ("A", "B"):
        assert np.array_equal(reused.real[g], alone.real[g])
        for table in ("simulated", "simulated_dts"):
            assert np.array_equal(getattr(reused, table)[("skin", g)],
                                  getattr(alone, table)[("skin", g)])
        assert np.array_equal(reused.grid_L_um[g], alone.grid_L_um[g])
    assert np.array_equal(reused.grid_fraction, alone.grid_fraction)

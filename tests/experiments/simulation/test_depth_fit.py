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

"""The observer family: each rule, parameter recovery, and the session's path = the batch path."""
import numpy as np
import pytest

from experiments.participant_model.person import PerceptionParameters, SimulatedPerson
from experiments.participant_model.observers import (OBSERVERS, BlockContext, answer_block,
                                              discrimination_axis, fit_observer, get_observer)

PARAMS = PerceptionParameters()
#: Four well separated classes on the default features (drops 1, 3, 8 s and the peak rate).
MEANS = np.array([[4.5, 6.3, 5.6, 7.0], [4.2, 6.1, 5.4, 6.4], [2.7, 4.6, 4.5, 3.7],
                  [1.7, 3.2, 3.4, 2.2]])


def _blocks(n_blocks, rng, means=MEANS, reps=3, noise=1.0):
    order = np.argsort(rng.random((n_blocks, 4 * reps)), axis=1) % 4
    x = means[order] + noise * rng.standard_normal(order.shape + (4,)) * PARAMS.noise_sd(means[order])
    ctx = BlockContext(np.repeat(means[None], n_blocks, axis=0), np.ones((n_blocks, 4)),
                       PARAMS.noise_sd, reps)
    return order, x, ctx


def test_family_names_and_documented_parameters():
    assert list(OBSERVERS) == ["absolute", "relative", "range_frequency", "display_learned"]
    for name, cls in OBSERVERS.items():
        assert cls.__doc__ and cls.name == name
        for param, (value, source) in cls.parameters().items():
            assert len(source) > 20, (name, param)   # every value has its reason
    with pytest.raises(ValueError, match="range_weight"):
        get_observer("range_frequency", range_weight=2.0)
    with pytest.raises(ValueError, match="expected one of"):
        get_observer("bayesian")


def test_absolute_matches_simulated_person_decide():
    rng = np.random.default_rng(20261124)
    person = SimulatedPerson(0.7e-3, params=PerceptionParameters(lapse_rate=0.0))
    for rid, m in enumerate(MEANS, start=1):
        person.learn(rid, m)
    order, x, ctx = _blocks(40, rng)
    got = answer_block(get_observer("absolute"), x, ctx, np.zeros(order.shape, bool), order)
    want = np.array([[person.decide(p, rng) - 1 for p in block] for block in x])
    np.testing.assert_array_equal(got, want)


def test_relative_observer_keeps_the_design_quota():
    rng = np.random.default_rng(7)
    order, x, ctx = _blocks(200, rng, noise=3.0)
    ans = answer_block(get_observer("relative"), x, ctx, np.zeros(order.shape, bool), order)
    counts = np.stack([(ans == c).sum(axis=1) for c in range(4)], axis=1)
    assert np.all(counts == 3)                    # each class named exactly 3 times per block
    # without noise the online rank is right about half the time (early trials are placed
    # from few percepts: the first always in the middle), well above chance (1/4)
    order, x, ctx = _blocks(400, rng, noise=0.0)
    ans = answer_block(get_observer("relative"), x, ctx, np.zeros(order.shape, bool), order)
    assert 0.4 < np.mean(ans == order) < 0.6
    assert np.all(ans[:, 0] == 1)                 # first trial: quantile 1/2 -> 2#


def test_axis_points_from_first_to_last_template():
    ctx = BlockContext(MEANS[None], np.ones((1, 4)), PARAMS.noise_sd)
    w, origin = discrimination_axis(ctx)
    z = (MEANS - origin[0]) @ w[0]
    assert z[0] == 0 and np.all(np.diff(z) > 0)


def test_range_frequency_first_trial_and_extremes():
    ctx = BlockContext(MEANS[None], np.ones((1, 4)), PARAMS.noise_sd)
    obs = get_observer("range_frequency")
    first = obs.choose(MEANS[None, :1], np.zeros((1, 0), int), ctx)
    assert first[0] == 2                          # J = 1/2 -> class 3 of 4 (floor(2) = 2)
    seq = MEANS[None, [0, 3, 1, 2]]               # 1#, 4#, then two in between
    ans = answer_block(obs, seq, ctx, np.zeros((1, 4), bool), np.zeros((1, 4), int))
    assert ans[0, 1] == 3                         # the most 4#-like so far: top category


@pytest.mark.parametrize("name, truth, grid", [
    ("absolute", {"lapse_rate": 0.2}, None),
    ("relative", {"lapse_rate": 0.1}, None),
    ("display_learned", {"lapse_rate": 0.3}, None),
    ("range_frequency", {"range_weight": 0.25, "lapse_rate": 0.05},
     {"range_weight": np.round(np.arange(0, 1.01, 0.05), 2)}),
])
def test_parameters_are_recovered(name, truth, grid):
    rng = np.random.default_rng(12345)
    order, x, ctx = _blocks(3000, rng, noise=1.5)
    obs = get_observer(name, **{k: v for k, v in truth.items() if k != "lapse_rate"})
    lapse = rng.random(order.shape) < truth["lapse_rate"]
    ans = answer_block(obs, x, ctx, lapse, rng.integers(0, 4, order.shape))
    fit = fit_observer(name, x, ans, ctx, grid)
    assert fit["lapse_rate"] == pytest.approx(truth["lapse_rate"], abs=0.02)
    if "range_weight" in truth:
        assert fit["range_weight"] == pytest.approx(truth["range_weight"], abs=0.051)


def test_responder_path_equals_batch_path():
    """The simulated responder's per-trial answers equal answer_block on the same percepts."""
    from experiments.responders.base import TrialStimulus  # noqa: F401 (the responder's types)
    from experiments.responders.simulated import SimulatedResponder
    from experiments.schedule import TrialSpec
    rng = np.random.default_rng(99)
    order, x, ctx = _blocks(5, rng, noise=2.0)
    for name in ("relative", "range_frequency", "absolute"):
        resp = SimulatedResponder(observer=name, lapse_rate=0.0, skin_thickness_um=700)
        person = resp._ensure_person()
        for rid, m in enumerate(MEANS, start=1):
            person.learn(rid, m)
        want = answer_block(get_observer(name), x, ctx, np.zeros(order.shape, bool), order)
        for b in range(x.shape[0]):
            resp._blocks.clear()
            for k in range(x.shape[1]):
                trial = TrialSpec(trial_index=k + 1, block="real", mode="real",
                                  roughness_id=int(order[b, k]) + 1, roughness_um=1.6,
                                  repetition=1)
                got = resp._decide(trial, x[b, k], np.random.default_rng(k), "real")
                assert got - 1 == want[b, k], (name, b, k)

"""Each replay hypothesis plays the profile its name and label say: checked against mpmath.

The expected values are evaluated here, independently of ``stimuli``: the printed Eq. 7 typed from
the paper's text at 40 digits, and the exact interface temperatures by numerical inversion
(``mpmath.invertlaplace``, Talbot) of the Laplace-domain solution derived in this file for a
skin slab (inner face held at T_S0) touching, through a resistance R, a material half-space or a
slab of thickness D with an insulated back.  The inputs (Table 1 properties, the recorded Eq. 5
resistances) are the profile's recorded parameters; the formulas are not.
"""
from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from stimuli.paper import REPLAY_NAMES

mp.mp.dps = 40

#: Table 1 of the paper: conductivity W/(m K), density kg/m^3, specific heat J/(kg K).
SKIN = (0.34, 1200.0, 3340.0)
STEEL = (14.9, 7900.0, 447.0)


def _alpha(p):
    return mp.mpf(p[0]) / (mp.mpf(p[1]) * p[2])


def _beta(p):
    return mp.sqrt(mp.mpf(p[0]) * p[1] * p[2])


def printed_eq7(t, L, R, Ts0, Tm0):
    """Eq. 7 as printed, at x = L+ (so mu (x - L) = 0): the paper's text, term by term."""
    t = mp.mpf(t)
    a_s = _alpha(SKIN)
    beta = _beta(SKIN) / _beta(STEEL)
    gamma = (beta - 1) / (beta + 1)
    H1 = (beta + 1) / (mp.mpf(R) * SKIN[0])
    rt = mp.sqrt(a_s * t)
    e_mr = (mp.exp(H1 * 0 + H1 ** 2 * a_s * t) * mp.erfc(H1 * rt + 0 / (2 * rt))
            - mp.exp(H1 * 2 * L + H1 ** 2 * a_s * t) * mp.erfc(H1 * rt + 2 * L / (2 * rt)))
    braces = mp.erfc(0 / (2 * rt)) + mp.erfc(2 * L / (2 * rt)) - e_mr
    return Tm0 + (Ts0 - Tm0) * (1 + gamma) / 2 * braces


def exact_interface(t, L, R, Ts0, Tm0, D, side):
    """Exact T_M(L+) ("material") or T_S(L-) ("skin") by inverting the Laplace solution.

    theta = (T - Tm0) / (Ts0 - Tm0). Skin 0 <= x <= L, theta(0) = 1: theta_S = 1/s + A sinh(q_s x).
    Material: theta_M = B e^{-q_m (x - L)} (half-space, D None) or B cosh(q_m (L + D - x)) /
    cosh(q_m D) (insulated slab).  Flux F = -lambda_S theta_S'(L) = K_m B with K_m = lambda_M q_m
    (tanh(q_m D)); theta_S(L) - theta_M(L) = R F.  Hence F = (1/s) / (R + 1/K_m + tanh(q_s L) /
    (lambda_S q_s)), theta_M(L+) = F / K_m, theta_S(L-) = theta_M(L+) + R F.
    """
    a_s, a_m = _alpha(SKIN), _alpha(STEEL)
    lam_s, lam_m = mp.mpf(SKIN[0]), mp.mpf(STEEL[0])

    def transform(s):
        qs, qm = mp.sqrt(s / a_s), mp.sqrt(s / a_m)
        km = lam_m * qm * (1 if D is None else mp.tanh(qm * D))
        flux = (1 / s) / (R + 1 / km + mp.tanh(qs * L) / (lam_s * qs))
        return flux / km if side == "material" else flux / km + R * flux

    theta = mp.invertlaplace(transform, mp.mpf(t), method="talbot")
    return Tm0 + (Ts0 - Tm0) * theta


def expected(name, t, par):
    """The hypothesis ``name``'s profile at ``t`` s, from the formula its name says it plays."""
    L = mp.mpf(par["skin"]["thickness_m"])
    R = mp.mpf(par["resistance_m2K_per_W"])
    Ts0, Tm0 = mp.mpf(par["skin_temperature_C"]), mp.mpf(par["material_temperature_C"])
    slab = mp.mpf("3e-3")
    if name == "printed":
        return printed_eq7(t, L, R, Ts0, Tm0)
    if name == "halfspace":
        return exact_interface(t, L, R, Ts0, Tm0, None, "material")
    if name == "slab":
        return exact_interface(t, L, R, Ts0, Tm0, slab, "material")
    if name == "skin":
        return exact_interface(t, L, R, Ts0, Tm0, slab, "skin")
    if name == "compensated":
        r_pad = mp.mpf(par["pad_resistance_m2K_W"])
        ts = exact_interface(t, L, R, Ts0, Tm0, slab, "skin")
        tm = exact_interface(t, L, R, Ts0, Tm0, slab, "material")
        return ts - r_pad / R * (ts - tm)
    raise AssertionError(f"no independent formula for replay {name!r}: add one")


def test_every_replay_hypothesis_has_an_independent_formula():
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    assert tuple(REPLAY_HYPOTHESES) == REPLAY_NAMES
    assert len(REPLAY_NAMES) == 5


@pytest.mark.parametrize("name", REPLAY_NAMES)
@pytest.mark.parametrize("group,sample", [("A", 1), ("B", 4)])
def test_replayed_profile_is_the_formula_its_name_says(name, group, sample):
    from experiments.protocol import load_protocol
    from experiments.session.setup import simulated_target_profile
    from experiments.simulation.replay import protocol_variant
    base = load_protocol("roughness_recognition")
    variant = protocol_variant(base, name)
    s = next(x for x in variant.samples if x.id == sample)
    prof = simulated_target_profile(variant, {}, group, None, s.id, s.roughness_um)
    par = prof.parameters
    assert par["resistance_source"] == "eq5"
    times = np.asarray(prof.times, dtype=float)
    temps = np.asarray(prof.temperature, dtype=float)
    # the skin and compensated profiles are slewed to 10 °C/s in their first 0.3 s
    for t in (1.0, 3.0, 8.0, 20.0):
        i = int(np.argmin(np.abs(times - t)))
        want = float(expected(name, times[i], par))
        # the display's 0.01 °C steps: half a step, and a margin for the inversion
        assert temps[i] == pytest.approx(want, abs=0.0051 + 1e-9), (name, group, sample, t)


def test_the_hypotheses_differ_where_their_names_say():
    # printed Eq. 7 and the exact 3 mm slab differ by more than 5 K at 20 s for 1#, group A
    # (22.46/28.23 °C against 21.92/23.13 °C at 3/20 s): a swapped label cannot pass the test above
    par = {"skin": {"thickness_m": 650e-6}, "skin_temperature_C": 35.5,
           "material_temperature_C": 20.0, "resistance_m2K_per_W": 6.494477522e-4,
           "pad_resistance_m2K_W": 6.34e-4}
    vals = {n: float(expected(n, 20.0, par)) for n in REPLAY_NAMES}
    assert vals["slab"] - vals["printed"] > 5.0
    assert abs(vals["halfspace"] - vals["printed"]) > 0.2
    assert vals["skin"] > vals["slab"]


def test_labels_and_profile_models_say_what_is_played():
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    words = {"printed": ("printed", "half-space"), "halfspace": ("exact", "half-space"),
             "slab": ("exact", "3 mm"), "skin": ("exact", "skin side", "3 mm"),
             "compensated": ("R_pad", "3 mm")}
    fields = {"printed": ("material", "paper-as-printed", "half-space"),
              "halfspace": ("material", "exact", "half-space"),
              "slab": ("material", "exact", "sample"), "skin": ("skin", "exact", "sample"),
              "compensated": ("compensated", "exact", "sample")}
    for name, h in REPLAY_HYPOTHESES.items():
        assert all(w in h.profile_model for w in words[name]), (name, h.profile_model)
        assert (h.target_side, h.method, h.replayed_material) == fields[name]
    assert "printed Eq. 7" in REPLAY_HYPOTHESES["printed"].label
    assert "Eq. 7" not in REPLAY_HYPOTHESES["slab"].label


@pytest.mark.parametrize("name", REPLAY_NAMES)
def test_a_replays_label_and_the_profile_model_it_recorded_agree(name):
    # what the session logs with every uploaded profile (method, parameters["plan"]) must name
    # the model the hypothesis says it plays: a printed-Eq. 7 replay recorded as "exact" fails
    from experiments.protocol import load_protocol
    from experiments.session.setup import simulated_target_profile
    from experiments.simulation.replay import REPLAY_HYPOTHESES, protocol_variant
    from stimuli.planner import plan_line
    h = REPLAY_HYPOTHESES[name]
    variant = protocol_variant(load_protocol("roughness_recognition"), name)
    for s in variant.samples:
        prof = simulated_target_profile(variant, {}, "A", None, s.id, s.roughness_um)
        plan = prof.parameters["plan"]
        methods = {plan["method"]} if "method" in plan else {p["method"] for p in plan["sides"]}
        models = [plan["model"]] + [p["model"] for p in plan.get("sides", ())]
        assert prof.method == h.method and methods == {h.method}, (name, prof.method, plan)
        half = h.replayed_material == "half-space"
        assert all(("half-space" in m) == half and ("slab" in m) == (not half) for m in models), \
            (name, models)
        line = plan_line(plan)
        assert (h.method in line) and ("as asked" in line) == (h.method != "exact"), line


def test_a_profile_asked_by_method_records_that_method_not_the_planners():
    from stimuli import Skin, target_profile
    for method in ("paper-as-printed", "paper"):
        prof = target_profile(method=method, roughness=1.6e-6, skin=Skin(650e-6), duration=2.0,
                              rate=100.0, cache=False)
        plan = prof.parameters["plan"]
        assert prof.method == plan["method"] == method and method in plan["model"]
        # its bound is its distance from the exact model, evaluated here independently
        T = np.asarray(prof.temperature)
        i = int(np.argmin(np.abs(np.asarray(prof.times) - 2.0)))
        par = prof.parameters
        exact = float(exact_interface(2.0, mp.mpf(par["skin"]["thickness_m"]),
                                      mp.mpf(par["resistance_m2K_per_W"]), 35.5, 20.0, None,
                                      "material"))
        assert abs(T[i] - exact) <= plan["bound_K"] + 0.005 + 1e-9
        assert plan["planner"]["method"] == "exact"          # the planner's answer, kept beside


def test_the_table2_replay_records_the_model_its_label_says():
    # the "T2 rise" claim's temperatures: each replay's recorded profile model is its own
    from experiments.simulation.figure9.scenarios import replay_models, table2_replay_temperatures
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    for name, h in REPLAY_HYPOTHESES.items():
        plans = []
        temps = table2_replay_temperatures(name, decisions=plans)
        assert len(plans) == len(temps)
        (model,) = replay_models(plans)
        assert model["method"] == h.method and model["count"] == len(temps), (name, model)
        assert ("half-space" in model["model"]) == (h.replayed_material == "half-space")
        if h.method == "exact":
            assert model["max_bound_K"] <= model["tolerance_K"] <= 1e-6

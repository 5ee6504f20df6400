"""Many simulated 15 + 15 studies of Figure 9, from the participant and observer models.

An emulated session (``thermocue run ... --responder simulated``) costs about a second per
participant; a claim's probability needs hundreds of studies per scenario.  This module
computes the noise-free features of persons on a grid of the two things that change a person's
physics (skin thickness L and the dermis' share d / L; the receptor depth follows) and of the
touch (contact force), once per group (:func:`build_pool`, the physics of
:mod:`experiments.participant_model.person`).  Every study then draws a *fresh* cohort, 15 persons per
group from the cohort's ranges, whose features are interpolated on that grid (bilinear in L and
d / L, linear in force: the drops within 0.01 K and the peak rate within 0.03 K/s of the direct
computation, ``test_studies.py``, against a perceptual noise of 0.3 K and 0.3 K/s plus 10 %), then their familiarisation percepts, the real and simulated blocks'
percepts in a random order and the answers of an observer (:mod:`.observers`, the very code the
simulated responder runs), all vectorised.

Variability a lab has (:class:`LabVariability`, each with a sensitivity row in the report):

* per-touch contact force (:mod:`experiments.participant_model.lab`, the emulated study's
  lab too): normal about 2.5 N with ``force_sd_N`` (default 0.25 N), clipped to 2.05-3 N (the
  display starts a contact when the force crosses the protocol's 2 N trigger, so no logged touch
  is lighter; the paper says "about 2 N" and gives no spread); it sets the Eq. 5 resistance of
  the real sample and of the finger–pad contact on every touch;
* the skin temperature between participants (uniform over the paper's 35.5-36 °C) and within a
  participant from touch to touch (``skin_temperature_sd_C``, default 0.1 K, the simulated
  responder's :attr:`~.person.PerceptionParameters.skin_temperature_sd_C`);
* a fresh cohort per study (``cohort_size=None``), or one cohort of ``cohort_size`` persons per
  group that every study draws from (the earlier design, for the sensitivity row);
* the pad sensor's lag (:func:`build_pool`'s ``sensor_tau_s``): the display makes its lagging
  sensor follow the target, so the pad face leads it by tau dT/dt (first order).

Where this differs from emulated sessions (it is *not* exactly equivalent)
-------------------------------------------------------------------------------
* The display tracks the target profile perfectly here (up to the sensor lag above); in a
  session the simulated participant feels the emulated pad's recorded contact temperature
  (controller lag, sensor noise, the finger's heat load): its features differ by at most
  ~0.005 K (K/s for the rate) against a perceptual noise of 0.3 (``test_studies.py`` measures it
  on two emulated sessions).
* Features are interpolated on the person grid, not computed per person (see above).
* Trial order within a block is a uniform random permutation of the 4 × 3 trials (the
  schedule's ``order = "random"`` is also a uniform permutation, from another seed).
* Random numbers come from one generator per task of a sweep, not from ``(seed, trial_index)``
  per person: the same distributions, different draws.
Everything else is the same: person ranges (:func:`~experiments.participant_model.person.draw_person`),
the session's own target profiles (:func:`experiments.session.setup.simulated_target_profile`,
rate limit included), the finger–pad contact resistance, the features, the noise model, the
familiarisation (one touch per real sample, by default), the lapse rule and the observer's
decision (:func:`.observers.answer_block`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# the lab (force and skin temperature per touch) is the emulated study's too
from experiments.participant_model.lab import DEFAULT_LAB, LabVariability
from stimuli.paper import (DERMIS_FRACTION_RANGE, GROUP_THICKNESS_UM,
                          REPLAY_NAMES, SKIN_TEMPERATURE_RANGE_C)

__all__ = ["PersonPool", "build_pool", "merge_pools", "StudyOutcome", "simulate_studies", "GROUPS",
           "imposed_features", "LabVariability", "DEFAULT_LAB", "FORCE_GRID_N", "person_features"]

#: The two groups and their skin thickness ranges, µm (§3.2).
GROUPS = ("A", "B")
#: Contact forces at which features are computed, N (the lab's range, 2-3 N: a touch crosses
#: the 2 N trigger); a touch's are interpolated linearly, within 0.01 K of the direct
#: computation (``test_studies.py``; the earlier 1/2/3 N grid was up to 0.14 K off at 1.5 N).
FORCE_GRID_N = tuple(float(f) for f in np.linspace(2.0, 3.0, 4))
#: Grid points over each group's thickness range and over d / L.
GRID_L, GRID_U = 5, 5




@dataclass
class PersonPool:
    """Noise-free features on a grid of persons and forces, per group.

    Attributes
    ----------
    grid_L_um : dict of str to ndarray (nL,)
        Skin thicknesses of the grid, µm.
    grid_fraction : ndarray (nU,)
        d / L of the grid (one value, ignored, for an absolute receptor depth).
    real : dict of str to ndarray (nL, nU, nForce, C, F)
        Per group: features of touching each real sample at :attr:`skin_reference_C`.
    simulated, simulated_dts : dict of (str, str) to ndarray (nL, nU, nForce, C, F)
        Per (hypothesis, group): features of touching the display replaying each sample at
        :attr:`skin_reference_C`, and their change per kelvin of skin temperature.
    params : PerceptionParameters
    receptor_depth_um : float or None
        Receptors at this depth below the surface for everyone (None: ``dermis_fraction`` of L).
    skin_reference_C, material_C : float, °C
    """

    grid_L_um: dict
    grid_fraction: np.ndarray
    real: dict
    simulated: dict
    simulated_dts: dict
    params: object
    skin_reference_C: float
    material_C: float
    receptor_depth_um: float | None = None
    roughness_um: tuple = ()
    settings: dict = field(default_factory=dict)

    @property
    def hypotheses(self) -> list:
        """Replay hypotheses in the pool, in :data:`stimuli.paper.REPLAY_NAMES` order."""
        return sorted({h for h, _ in self.simulated}, key=REPLAY_NAMES.index)


def _lead(t, T, tau, max_rate=None):
    """The pad face when a sensor of time constant ``tau`` is made to follow ``T``: T + tau T',
    slewed to ``max_rate`` (K/s) when given, as the display's rate limit would.

    Returns ``(face, peak)``: the face and the peak rate of T + tau T' before slewing, K/s.
    """
    T = np.asarray(T, dtype=float)
    if not tau:
        return T, 0.0
    t = np.asarray(t, float)
    face = T + float(tau) * np.gradient(T, t)
    peak = float(np.max(np.abs(np.diff(face) / np.diff(t)))) if t.size > 1 else 0.0
    if max_rate is not None and peak > max_rate:
        out = face.copy()
        steps = float(max_rate) * np.diff(t)
        for i in range(1, out.size):
            out[i] = out[i - 1] + np.clip(face[i] - out[i - 1], -steps[i - 1], steps[i - 1])
        face = out
    return face, peak


def build_pool(protocol="roughness_recognition", hypotheses=REPLAY_NAMES, seed: int = 0,
               params=None, receptor_depth_um: float | None = None,
               dermis_fraction=DERMIS_FRACTION_RANGE, sensor_tau_s: float = 0.0,
               real_from: PersonPool | None = None, groups=GROUPS) -> PersonPool:
    """Features of the person grid of each group, for the real samples and each replay.

    Parameters
    ----------
    protocol : Protocol or str
        The protocol whose samples, temperatures and simulated profiles are used.
    hypotheses : sequence of str
        Replay hypotheses (:data:`experiments.simulation.replay.REPLAY_HYPOTHESES`).
    seed : int
        Recorded only (the grid is deterministic; studies draw their persons).
    params : PerceptionParameters, optional
    receptor_depth_um : float, µm, optional
        Put every person's receptors at this depth below the skin surface (both groups alike)
        instead of at ``1 - dermis_fraction`` of their skin thickness.
    dermis_fraction : (low, high)
        Range of ``d / L`` persons are drawn from (the cohort's 0.55–0.65).
    sensor_tau_s : float, s
        The pad sensor's time constant (0: the pad face is the target).  The face, T + tau T',
        is slewed to the protocol's ``[display] max_rate_C_per_s`` where it would be faster
        (a display cannot drive its face faster); the unslewed peak rate is recorded in
        ``settings["sensor_lag_peak_rate_C_per_s"]``.
    real_from : PersonPool, optional
        A pool of the same persons (receptor depth, d / L range) whose real-sample features are
        reused (the sensor lag changes only the replayed ones).
    groups : sequence of str
        The groups to build (:func:`merge_pools` joins pools of different groups).
    """
    from experiments.participant_model.person import PerceptionParameters
    from experiments.protocol import load_protocol
    from experiments.simulation.replay import protocol_variant

    params = params or PerceptionParameters()
    base = protocol if hasattr(protocol, "data") else load_protocol(protocol)
    variants = {h: protocol_variant(base, h) for h in hypotheses}
    t_ref = float(np.mean(SKIN_TEMPERATURE_RANGE_C))
    fractions = _grid_fractions(receptor_depth_um, dermis_fraction)
    if real_from is not None and (real_from.receptor_depth_um != receptor_depth_um
                                  or tuple(real_from.settings["dermis_fraction"]) != tuple(dermis_fraction)):
        raise ValueError("build_pool: real_from: expected a pool of the same persons (receptor "
                         "depth and d / L range)")
    max_rate = float(base.display.max_rate_C_per_s)
    surfaces, peak_rate = _replay_surfaces(variants, base.samples, groups, sensor_tau_s, max_rate)
    grid_L, real, simulated, simulated_dts = {}, {}, {}, {}
    people, display_plans = [], []
    for group in groups:
        grid_L[group] = np.linspace(*GROUP_THICKNESS_UM[group], GRID_L)
        real[group], sims, dsims = _group_features(
            base, variants, group, grid_L[group], fractions, receptor_depth_um, t_ref, params,
            surfaces, real_from, people, display_plans)
        for h in variants:
            simulated[(h, group)] = sims[h]
            simulated_dts[(h, group)] = dsims[h]
    t_mat = base.simulation.material_temperature_C
    return PersonPool(grid_L_um=grid_L, grid_fraction=fractions, real=real, simulated=simulated,
                      simulated_dts=simulated_dts, params=params, skin_reference_C=t_ref,
                      material_C=float(t_mat), receptor_depth_um=receptor_depth_um,
                      roughness_um=tuple(s.roughness_um for s in base.samples),
                      settings={"seed": int(seed), "dermis_fraction": tuple(dermis_fraction),
                                "sensor_tau_s": float(sensor_tau_s),
                                "sensor_lag_peak_rate_C_per_s": peak_rate,
                                "max_rate_C_per_s": max_rate,
                                "replay_skin_C": float(base.simulation.skin_temperature_C),
                                "model_tolerance_C": float(params.model_tolerance_C),
                                "planner_decisions": {
                                    "real": _planner_decisions(
                                        [q for person in people for q in person.real_plans.values()]),
                                    "display": _planner_decisions(display_plans)},
                                "grid": f"{GRID_L} thicknesses x {len(fractions)} d/L x "
                                        f"{len(FORCE_GRID_N)} forces per group"})


def _grid_fractions(receptor_depth_um, dermis_fraction) -> np.ndarray:
    """The pool grid's d / L values (one, ignored, for an absolute receptor depth)."""
    if receptor_depth_um is not None:
        return np.array([0.0])
    if dermis_fraction[0] == dermis_fraction[1]:          # one d / L for everyone
        return np.array([float(dermis_fraction[0])])
    return np.linspace(*dermis_fraction, GRID_U)


def _replay_surfaces(variants, samples, groups, sensor_tau_s, max_rate):
    """The pad face of each replay profile per (hypothesis, group): ``[(t, °C), ...]`` per
    sample (the sensor's lead, slewed), and the largest unslewed peak rate, K/s."""
    from experiments.session.setup import simulated_target_profile
    peak_rate = 0.0
    surfaces = {}
    for group in groups:
        for h, proto in variants.items():
            surfaces[(h, group)] = []
            for s in samples:
                pr = simulated_target_profile(proto, {}, group, None, s.id, s.roughness_um)
                face, peak = _lead(pr.times, pr.temperature, sensor_tau_s, max_rate)
                peak_rate = max(peak_rate, peak)
                surfaces[(h, group)].append((pr.times, face))
    return surfaces, peak_rate


def _group_features(base, variants, group, Ls, fractions, receptor_depth_um, t_ref, params,
                    surfaces, real_from, people, display_plans):
    """One group's grid: real features (nL, nU, nForce, C, 4) and, per hypothesis, the replays'
    features and their change per kelvin of skin.  Appends the grid's persons to ``people``
    and the display's plans to ``display_plans``."""
    from experiments.participant_model.person import SimulatedPerson
    r = np.zeros((len(Ls), len(fractions), len(FORCE_GRID_N), len(base.samples), 4))
    sims = {h: np.zeros_like(r) for h in variants}
    dsims = {h: np.zeros_like(r) for h in variants}
    for i, L_um in enumerate(Ls):
        for j, frac in enumerate(fractions):
            if receptor_depth_um is not None:
                frac = 1.0 - receptor_depth_um / L_um
                if not 0.0 < frac < 1.0:
                    raise ValueError(f"build_pool: receptor_depth_um: expected a depth inside "
                                     f"the skin ({L_um:.0f} µm), got {receptor_depth_um!r}")
            p = SimulatedPerson(L_um * 1e-6, float(frac), t_ref, params)
            people.append(p)
            p1 = SimulatedPerson(L_um * 1e-6, float(frac), t_ref + 1.0, params)
            for k, force in enumerate(FORCE_GRID_N):
                if real_from is not None:
                    r[i, j, k] = real_from.real[group][i, j, k]
                else:
                    r[i, j, k] = _real_features(p, base, force)
                _replay_features(p, p1, base.simulation, force, variants, group, surfaces,
                                 display_plans, sims, dsims, (i, j, k))
    return r, sims, dsims


def _real_features(person, base, force):
    """Features of ``person`` touching each real sample of ``base`` at ``force`` N: (C, 4)."""
    return [person.features(*person.feel_real(s.roughness_m, material=base.material.name,
                                              sample_thickness_m=base.material.thickness_m,
                                              material_temperature_C=base.simulation.material_temperature_C,
                                              force_N=force))
            for s in base.samples]


def _replay_features(p, p1, sim0, force, variants, group, surfaces, display_plans, sims, dsims,
                     at):
    """Every replay's features at one grid point (``at``) into ``sims``, and their change per
    kelvin of skin (``p1``: ``p`` 1 K warmer) into ``dsims``."""
    from stimuli import contact_resistance, material
    r_pad = float(contact_resistance(sim0.pad_roughness_m, skin=p.skin,
                                     material=material(sim0.pad_material), force=force))
    responses = {}     # same skin and resistance: shared by every replay
    for h in variants:
        surf = surfaces[(h, group)]
        f0 = imposed_features(p, surf, r_pad, responses, display_plans)
        sims[h][at] = f0
        dsims[h][at] = imposed_features(p1, surf, r_pad, responses, display_plans) - f0


def merge_pools(pools) -> PersonPool:
    """One pool from pools of different groups (same persons' settings, same hypotheses)."""
    first = pools[0]
    out = PersonPool(grid_L_um={}, grid_fraction=first.grid_fraction, real={}, simulated={},
                     simulated_dts={}, params=first.params,
                     skin_reference_C=first.skin_reference_C, material_C=first.material_C,
                     receptor_depth_um=first.receptor_depth_um, roughness_um=first.roughness_um,
                     settings=dict(first.settings))
    for p in pools:
        for name in ("grid_L_um", "real", "simulated", "simulated_dts"):
            getattr(out, name).update(getattr(p, name))
    out.settings["planner_decisions"] = {
        path: _merge_decisions([p.settings["planner_decisions"][path] for p in pools])
        for path in ("real", "display")}
    return out


def _planner_decisions(plans) -> dict:
    """The scene planner's decisions over many evaluations: per model chosen, how often, its
    method, tolerance and the largest error bound (:func:`stimuli.planner.plan_summary`)."""
    from stimuli.planner import plan_summary
    out = {}
    for plan in plans:
        d = plan_summary(plan)
        e = out.setdefault(d["model"], {"count": 0, "method": d["method"],
                                        "tolerance_K": d["tolerance_K"], "max_bound_K": 0.0})
        e["count"] += 1
        e["max_bound_K"] = max(e["max_bound_K"], float(d["bound_K"] or 0.0))
    return out


def _merge_decisions(parts) -> dict:
    out = {}
    for part in parts:
        for model, e in part.items():
            m = out.setdefault(model, dict(e, count=0, max_bound_K=0.0))
            m["count"] += e["count"]
            m["max_bound_K"] = max(m["max_bound_K"], e["max_bound_K"])
    return out


def _grid_weights(x, grid):
    """Indices and weights of linear interpolation of ``x`` on the increasing ``grid``."""
    x = np.clip(x, grid[0], grid[-1])
    if grid.size == 1:
        z = np.zeros(x.shape, dtype=int)
        return z, z, np.zeros(x.shape)
    i = np.clip(np.searchsorted(grid, x, side="right") - 1, 0, grid.size - 2)
    w = (x - grid[i]) / (grid[i + 1] - grid[i])
    return i, i + 1, w


def person_features(table, grid_L, grid_fraction, L_um, fraction):
    """Bilinear interpolation of a grid ``table`` (nL, nU, ...) at persons (L_um, fraction)."""
    i0, i1, wi = _grid_weights(np.asarray(L_um, float), np.asarray(grid_L, float))
    j0, j1, wj = _grid_weights(np.asarray(fraction, float), np.asarray(grid_fraction, float))
    extra = (slice(None),) + (None,) * (table.ndim - 2)
    wi, wj = wi[extra], wj[extra]
    return ((1 - wi) * (1 - wj) * table[i0, j0] + wi * (1 - wj) * table[i1, j0]
            + (1 - wi) * wj * table[i0, j1] + wi * wj * table[i1, j1])


def imposed_features(person, surfaces, pad_resistance, cache: dict | None = None,
                     plans: list | None = None) -> np.ndarray:
    """Features of ``person`` touching the pad at each of ``surfaces`` (list of (t, °C)).

    The same as ``person.features(*person.feel_imposed(t, T, pad_resistance=...))`` for each:
    every history is planned by the display planner
    (:func:`stimuli.display_planner.plan_display`, at ``person.params.model_tolerance_C``, the
    physics the person states: homogeneous skin without perfusion), and the planned model is
    evaluated by linear superposition: the skin's response is linear and time-invariant in the
    surface temperature (linear between uniform samples), so two evaluations of the planned model
    (:func:`stimuli.skin_response`, homogeneous skin: a unit jump at t = 0 decaying linearly to
    the first sample, and a unit hat at the first sample) give every profile's response by a
    convolution; equal
    to the direct computation to ~1e-12 K (``tests/experiments/simulation/test_studies.py``).
    ``plans``: a list the plans are appended to (the Monte Carlo's record of the decisions).
    """
    from stimuli import skin_response
    from stimuli.display_planner import plan_display
    out = []
    cache = {} if cache is None else cache      # the unit responses: per skin, resistance, model
    t_s = person.skin_temperature_C
    skin = person.skin
    R = float(pad_resistance)
    for t, surface in surfaces:
        t_in = np.asarray(t, dtype=float)
        g_in = np.asarray(surface, dtype=float)
        ok = np.isfinite(t_in) & np.isfinite(g_in)
        t_in, g_in = t_in[ok] - t_in[ok][0], g_in[ok]
        grid = person.time_grid(min(person.params.duration_s, float(t_in[-1])))
        n = grid.size
        d = np.interp(grid, t_in, g_in) - t_s
        rate = person.params.sample_rate_Hz
        plan = plan_display(skin, skin.dermis, R, (n - 1) / rate, rate, d,
                            tolerance=person.params.model_tolerance_C)
        if plans is not None:
            plans.append(plan)
        key = (n, plan.layered, plan.perfusion)
        if key not in cache:
            e0 = np.full(n, t_s)
            e0[0] += 1.0
            e1 = np.full(n, t_s)
            e1[1] += 1.0
            if plan.layered or plan.perfusion:      # the physics stated above has neither
                raise AssertionError(f"imposed_features: the plan kept {plan.describe()!r}")
            kw = dict(initial_temperature=t_s, depth=skin.dermis, resistance=R)
            unit = [skin_response(skin, grid, e, **kw) for e in (e0, e1)]
            cache[key] = tuple(np.asarray(u) - t_s for u in unit)
        r0, r1 = cache[key]
        receptor = t_s + d[0] * r0 + np.convolve(d[1:], r1)[:n]
        out.append(person.features(grid, receptor))
    return np.array(out)


@dataclass
class StudyOutcome:
    """Correct answers of many simulated studies.

    Attributes
    ----------
    correct : ndarray of int, shape (S, P, 2, C)
        Correct answers per study, participant, mode (0 real, 1 simulated) and sample.
    answers : ndarray of int, shape (S, P, 2, C, C)
        Confusion counts: [..., true class, answered class].
    groups : ndarray of str, shape (P,)
    repetitions : int
        Trials per sample and mode for each participant.
    """

    correct: np.ndarray
    answers: np.ndarray
    groups: np.ndarray
    repetitions: int
    roughness_um: tuple = ()

    def proportions(self) -> np.ndarray:
        """Expected proportion correct, shape (groups, 2 modes, C): mean over studies."""
        out = []
        for g in GROUPS:
            sel = self.correct[:, self.groups == g]
            out.append(sel.mean(axis=(0, 1)) / self.repetitions)
        return np.array(out)


def _percepts(features, params, rng):
    return features + rng.standard_normal(features.shape) * params.noise_sd(features)


def _draw_cohorts(pool, group, n_studies, n_per_group, lab, rng):
    """Persons of every study of one group: (S, n) arrays of L (µm), d / L and skin °C."""
    lo, hi = GROUP_THICKNESS_UM[group]
    flo, fhi = pool.settings["dermis_fraction"]
    tlo, thi = lab.skin_temperature_C
    if lab.cohort_size is None:
        shape = (n_studies, n_per_group)
        return (rng.uniform(lo, hi, shape), rng.uniform(flo, fhi, shape), rng.uniform(tlo, thi, shape))
    if n_per_group > lab.cohort_size:
        raise ValueError(f"simulate_studies: n_per_group: expected at most the cohort's "
                         f"{lab.cohort_size}, got {n_per_group}")
    crng = np.random.default_rng([pool.settings["seed"], GROUPS.index(group), 0xC0])
    people = (crng.uniform(lo, hi, lab.cohort_size), crng.uniform(flo, fhi, lab.cohort_size),
              crng.uniform(tlo, thi, lab.cohort_size))
    idx = np.argsort(rng.random((n_studies, lab.cohort_size)), axis=1)[:, :n_per_group]
    return tuple(v[idx] for v in people)


def _force_weights(force):
    """Linear interpolation weights of ``force`` (any shape) on :data:`FORCE_GRID_N`: (..., nForce)."""
    grid = np.asarray(FORCE_GRID_N, float)
    i0, i1, w = _grid_weights(force, grid)
    out = np.zeros(force.shape + (grid.size,))
    # i1 = i0 + 1; on a one-point grid i1 = i0 and w = 0, so the weight 1 is written last
    np.put_along_axis(out, i1[..., None], w[..., None], axis=-1)
    np.put_along_axis(out, i0[..., None], (1 - w)[..., None], axis=-1)
    return out


def _by_class(table):
    """A (..., nForce, C, F) table as (..., C, nForce, F), C-contiguous: one touch's rows
    (every force of one person's one class) are one block, which :func:`_touch_features`
    gathers.  Applied to a pool's grid tables (small) before the persons are interpolated."""
    return np.ascontiguousarray(np.swapaxes(table, -3, -2))


def _touch_features(base, dts, classes, force_w, skin_delta, real_scale):
    """Features of touches: base/dts (B, C, nForce, F) (:func:`_by_class`), classes (B, T),
    force_w (B, T, nForce).

    Real touches scale exactly with the skin–sample difference (``real_scale`` (B, T)); replayed
    ones add ``skin_delta`` (B, T) K times their change per kelvin.  A touch's rows are taken as
    whole blocks (``np.take``): the same (B, T, nForce, F) array as indexing ``[b, :, classes]``
    in the force-first layout, several times faster.
    """
    B, C = base.shape[:2]
    rows = np.arange(B)[:, None] * C + classes                          # (B, T)

    def gather(table):                                                  # (B, T, nForce, F)
        return np.take(table.reshape(B * C, *table.shape[2:]), rows, axis=0)
    f = np.einsum("btk,btkf->btf", force_w, gather(base))
    if dts is not None:
        f = f + skin_delta[..., None] * np.einsum("btk,btkf->btf", force_w, gather(dts))
    if real_scale is not None:
        f = f * real_scale[..., None]
    return f


def simulate_studies(pool: PersonPool, hypothesis: str, observer, n_studies: int = 500,
                     n_per_group: int = 15, repetitions: int = 3, familiarise_reps: int = 1,
                     params=None, seed=0, variability: LabVariability | None = None) -> StudyOutcome:
    """Simulate ``n_studies`` studies of ``n_per_group`` persons per group.

    Parameters
    ----------
    pool : PersonPool
    hypothesis : str
        Which replay's simulated features to use (must be in the pool).
    observer : Observer
    n_studies, n_per_group, repetitions, familiarise_reps : int
        The design: ``repetitions`` presentations of each sample per block (the paper: 3),
        ``familiarise_reps`` familiarisation touches per sample (the paper: 1).
    params : PerceptionParameters, optional
        Noise and lapse (default the pool's); the features do not depend on them.
    seed : int or tuple of int
        A tuple names a task of a sweep (:mod:`.sweep`): its random numbers are its own.
    variability : LabVariability, optional
        Default :data:`DEFAULT_LAB`.
    """
    from experiments.participant_model.observers import BlockContext, answer_block
    params = params or pool.params
    lab = DEFAULT_LAB if variability is None else variability
    rng = np.random.default_rng([*(int(w) for w in np.atleast_1d(seed)), 0x57D1])
    R0, S0, dS, T_s, groups = [], [], [], [], []
    for g in GROUPS:
        L, frac, ts = _draw_cohorts(pool, g, n_studies, n_per_group, lab, rng)
        args = (pool.grid_L_um[g], pool.grid_fraction, L.ravel(), frac.ravel())
        for out, table in ((R0, pool.real[g]), (S0, pool.simulated[(hypothesis, g)]),
                           (dS, pool.simulated_dts[(hypothesis, g)])):
            # interpolated per element: the by-class grid gives the by-class persons directly
            by_class = _by_class(table)                                 # (nL, nU, C, nF, F)
            out.append(person_features(by_class, *args).reshape(L.shape + by_class.shape[2:]))
        T_s.append(ts)
        groups += [g] * n_per_group
    real, simf, dsim = (np.concatenate(x, axis=1) for x in (R0, S0, dS))   # (S, P, C, nF, F)
    skin = np.concatenate(T_s, axis=1)                                        # (S, P)
    S, P, C, NF, F = real.shape
    B = S * P
    real, simf, dsim = (x.reshape(B, C, NF, F) for x in (real, simf, dsim))
    skin = skin.reshape(B)
    T = C * repetitions

    def touches(n):
        force = lab.draw_forces(rng, (B, n))
        skin_t = lab.draw_skin_temperatures(rng, skin[:, None], (B, n))
        real_scale = (skin_t - pool.material_C) / (pool.skin_reference_C - pool.material_C)
        return _force_weights(force), skin_t - pool.skin_reference_C, real_scale

    def familiarise(base, dts, is_real):
        classes = np.tile(np.arange(C), familiarise_reps)[None].repeat(B, axis=0)   # (B, reps*C)
        fw, delta, scale = touches(classes.shape[1])
        f = _touch_features(base, dts, classes, fw, delta, scale if is_real else None)
        x = _percepts(f, params, rng).reshape(B, familiarise_reps, C, F)
        return x.mean(axis=1)

    counts = np.full((B, C), float(familiarise_reps))
    ctx_real = BlockContext(familiarise(real, None, True), counts, params.noise_sd, repetitions)
    if observer.template_mode_for_simulated == "simulated":
        ctx_sim = BlockContext(familiarise(simf, dsim, False), counts, params.noise_sd, repetitions)
    else:
        ctx_sim = ctx_real
    correct = np.zeros((B, 2, C), dtype=int)
    confusion = np.zeros((B, 2, C, C), dtype=int)
    for m, (base, dts, ctx) in enumerate(((real, None, ctx_real), (simf, dsim, ctx_sim))):
        order = np.argsort(rng.random((B, T)), axis=1) % C                  # true classes
        fw, delta, scale = touches(T)
        f = _touch_features(base, dts, order, fw, delta, scale if m == 0 else None)
        x = _percepts(f, params, rng)
        lapse = rng.random((B, T)) < params.lapse_rate
        guesses = rng.integers(0, C, (B, T))
        ans = answer_block(observer, x, ctx, lapse, guesses)
        np.add.at(confusion[:, m], (np.arange(B)[:, None], order, ans), 1)
        correct[:, m] = confusion[:, m][:, np.arange(C), np.arange(C)]
    return StudyOutcome(correct=correct.reshape(S, P, 2, C),
                        answers=confusion.reshape(S, P, 2, C, C),
                        groups=np.array(groups), repetitions=repetitions,
                        roughness_um=pool.roughness_um)

"""Many simulated 15 + 15 studies of Figure 9, from the participant and observer models.

An emulated session (``thermocue run ... --responder simulated``) costs about a second per
participant; a claim's probability needs hundreds of studies per scenario.  This module
computes the same participants' noise-free features once (a *pool* of persons per group, the
physics of :mod:`experiments.simulation.person`), then draws studies: 15 persons per group from
the pool, their familiarisation percepts, the real and simulated blocks' percepts in a random
order, and the answers of an observer (:mod:`.observers`, the very code the simulated responder
runs), all vectorised.

Where this differs from emulated sessions (it is *not* exactly equivalent)
-------------------------------------------------------------------------------
* The display tracks the target profile perfectly here; in a session the simulated participant
  feels the emulated pad's recorded contact temperature (controller lag, sensor noise, the
  finger's heat load): its features differ by at most ~0.005 K (K/s for the rate) against a
  perceptual noise of 0.3 (``test_studies.py`` measures it on two emulated sessions).
* Persons are drawn without replacement from a pool of ``pool_size`` per group (default 100),
  not afresh for every study: between-study variation of the people is that of 15 of 100.
* The trial-to-trial skin-temperature jitter (``skin_temperature_sd_C``, 0.1 K against a ~15 K
  skin–sample difference) is left out; each person touches at its own skin temperature.
* Trial order within a block is a uniform random permutation of the 4 × 3 trials (the
  schedule's ``order = "random"`` is also a uniform permutation, from another seed).
* Random numbers come from one generator per scenario, not from ``(seed, trial_index)`` per
  person: the same distributions, different draws.
Everything else is the same: person draws (:func:`~experiments.simulation.person.draw_person`
ranges), the session's own target profiles (:func:`experiments.session.setup.
simulated_target_profile`, rate limit included), the finger–pad contact resistance, the
features, the noise model, the familiarisation (one touch per real sample, by default), the
lapse rule and the observer's decision (:func:`.observers.answer_block`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from stimuli.paper import DERMIS_FRACTION_RANGE, GROUP_THICKNESS_UM, REPLAY_NAMES

__all__ = ["PersonPool", "build_pool", "StudyOutcome", "simulate_studies", "GROUPS",
           "imposed_features"]

#: The two groups and their skin thickness ranges, µm (§3.2).
GROUPS = ("A", "B")


@dataclass
class PersonPool:
    """Noise-free features of a pool of simulated persons.

    Attributes
    ----------
    real : dict of str to ndarray (N, C, F)
        Per group: features of touching each real sample.
    simulated : dict of (str, str) to ndarray (N, C, F)
        Per (hypothesis, group): features of touching the display replaying each sample.
    thickness_um : dict of str to ndarray (N,)
    params : PerceptionParameters
    receptor_depth_um : float or None
        Receptors at this depth below the surface for everyone (None: ``dermis_fraction`` of L).
    """

    real: dict
    simulated: dict
    thickness_um: dict
    params: object
    receptor_depth_um: float | None = None
    roughness_um: tuple = ()
    settings: dict = field(default_factory=dict)


def build_pool(protocol="roughness_recognition", hypotheses=REPLAY_NAMES,
               pool_size: int = 100, seed: int = 0, params=None, receptor_depth_um: float | None = None,
               dermis_fraction=DERMIS_FRACTION_RANGE) -> PersonPool:
    """Draw ``pool_size`` persons per group and compute their noise-free features.

    Parameters
    ----------
    protocol : Protocol or str
        The protocol whose samples, temperatures and simulated profiles are used.
    hypotheses : sequence of str
        Replay hypotheses (:data:`experiments.simulation.replay.REPLAY_HYPOTHESES`).
    pool_size : int
    seed : int
    params : PerceptionParameters, optional
    receptor_depth_um : float, µm, optional
        Put every person's receptors at this depth below the skin surface (both groups alike)
        instead of at ``1 - dermis_fraction`` of their skin thickness.
    dermis_fraction : (low, high)
        Range of ``d / L`` persons are drawn from (the cohort's 0.55–0.65).
    """
    from experiments.simulation.person import PerceptionParameters, SimulatedPerson, draw_person
    from experiments.protocol import load_protocol
    from experiments.session.setup import simulated_target_profile
    from experiments.simulation.replay import protocol_variant

    params = params or PerceptionParameters()
    base = protocol if hasattr(protocol, "data") else load_protocol(protocol)
    variants = {h: protocol_variant(base, h) for h in hypotheses}
    samples = base.samples
    rng = np.random.default_rng([int(seed), 0x9001])
    real, simulated, thickness = {}, {}, {}
    for group in GROUPS:
        persons = []
        for _ in range(int(pool_size)):
            p = draw_person(group, rng, params=params, dermis_fraction=dermis_fraction)
            if receptor_depth_um is not None:
                frac = 1.0 - receptor_depth_um * 1e-6 / p.skin_thickness_m
                if not 0.0 < frac < 1.0:
                    raise ValueError(f"build_pool: receptor_depth_um: expected a depth inside "
                                     f"the skin ({p.skin_thickness_m * 1e6:.0f} µm), got "
                                     f"{receptor_depth_um!r}")
                p = SimulatedPerson(p.skin_thickness_m, frac, p.skin_temperature_C, params)
            persons.append(p)
        thickness[group] = np.array([p.skin_thickness_m * 1e6 for p in persons])
        t_mat = base.simulation.material_temperature_C
        thick_m = base.material.thickness_m
        real[group] = np.array([[p.features(*p.feel_real(s.roughness_m, material=base.material.name,
                                                         sample_thickness_m=thick_m,
                                                         material_temperature_C=t_mat))
                                 for s in samples] for p in persons])
        for h, proto in variants.items():
            sim = proto.simulation
            profiles = [simulated_target_profile(proto, {}, group, None, s.id, s.roughness_um)
                        for s in samples]
            rows = []
            for p in persons:
                r_pad = p.pad_resistance(sim.pad_roughness_m, sim.pad_material)
                rows.append(imposed_features(p, [(pr.times, pr.temperature) for pr in profiles],
                                             r_pad))
            simulated[(h, group)] = np.array(rows)
    return PersonPool(real=real, simulated=simulated, thickness_um=thickness, params=params,
                      receptor_depth_um=receptor_depth_um,
                      roughness_um=tuple(s.roughness_um for s in samples),
                      settings={"pool_size": int(pool_size), "seed": int(seed),
                                "dermis_fraction": tuple(dermis_fraction)})


def imposed_features(person, surfaces, pad_resistance) -> np.ndarray:
    """Features of ``person`` touching the pad at each of ``surfaces`` (list of (t, °C)).

    The same as ``person.features(*person.feel_imposed(t, T, pad_resistance=...))`` for each,
    computed by linear superposition: the skin's response is linear and time-invariant in the
    surface temperature (linear between uniform samples), so two calls of
    :func:`stimuli.skin_response` (a unit jump at t = 0 decaying linearly to the first sample,
    and a unit hat at the first sample) give every profile's response by a convolution; equal
    to the direct computation to ~1e-12 K (``tests/experiments/simulation/test_studies.py``).
    """
    from stimuli import skin_response
    out = []
    cache = {}
    t_s = person.skin_temperature_C
    skin = person.skin
    for t, surface in surfaces:
        t_in = np.asarray(t, dtype=float)
        g_in = np.asarray(surface, dtype=float)
        ok = np.isfinite(t_in) & np.isfinite(g_in)
        t_in, g_in = t_in[ok] - t_in[ok][0], g_in[ok]
        grid = person.time_grid(min(person.params.duration_s, float(t_in[-1])))
        n = grid.size
        if n not in cache:
            e0 = np.full(n, t_s)
            e0[0] += 1.0
            e1 = np.full(n, t_s)
            e1[1] += 1.0
            kw = dict(initial_temperature=t_s, depth=skin.dermis, resistance=float(pad_resistance))
            cache[n] = (np.asarray(skin_response(skin, grid, e0, **kw)) - t_s,
                        np.asarray(skin_response(skin, grid, e1, **kw)) - t_s)
        r0, r1 = cache[n]
        d = np.interp(grid, t_in, g_in) - t_s
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


def simulate_studies(pool: PersonPool, hypothesis: str, observer, n_studies: int = 500,
                     n_per_group: int = 15, repetitions: int = 3, familiarise_reps: int = 1,
                     params=None, seed: int = 0) -> StudyOutcome:
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
    seed : int
    """
    from experiments.simulation.observers import BlockContext, answer_block
    params = params or pool.params
    rng = np.random.default_rng([int(seed), 0x57D1])
    feats_r, feats_s, groups = [], [], []
    for g in GROUPS:
        n_pool = pool.real[g].shape[0]
        if n_per_group > n_pool:
            raise ValueError(f"simulate_studies: n_per_group: expected at most the pool's "
                             f"{n_pool}, got {n_per_group}")
        idx = np.argsort(rng.random((n_studies, n_pool)), axis=1)[:, :n_per_group]   # (S, n)
        feats_r.append(pool.real[g][idx])
        feats_s.append(pool.simulated[(hypothesis, g)][idx])
        groups += [g] * n_per_group
    real = np.concatenate(feats_r, axis=1)          # (S, P, C, F)
    simf = np.concatenate(feats_s, axis=1)
    S, P, C, F = real.shape
    B = S * P
    real, simf = real.reshape(B, C, F), simf.reshape(B, C, F)
    fam = _percepts(np.repeat(real[:, None], familiarise_reps, axis=1), params, rng).mean(axis=1)
    counts = np.full((B, C), float(familiarise_reps))
    ctx_real = BlockContext(fam, counts, params.noise_sd, repetitions)
    if observer.template_mode_for_simulated == "simulated":
        fam_s = _percepts(np.repeat(simf[:, None], familiarise_reps, axis=1), params, rng).mean(axis=1)
        ctx_sim = BlockContext(fam_s, counts, params.noise_sd, repetitions)
    else:
        ctx_sim = ctx_real
    T = C * repetitions
    correct = np.zeros((B, 2, C), dtype=int)
    confusion = np.zeros((B, 2, C, C), dtype=int)
    for m, (feats, ctx) in enumerate(((real, ctx_real), (simf, ctx_sim))):
        order = np.argsort(rng.random((B, T)), axis=1) % C                  # true classes
        x = _percepts(np.take_along_axis(feats, order[..., None], axis=1), params, rng)
        lapse = rng.random((B, T)) < params.lapse_rate
        guesses = rng.integers(0, C, (B, T))
        ans = answer_block(observer, x, ctx, lapse, guesses)
        np.add.at(confusion[:, m], (np.arange(B)[:, None], order, ans), 1)
        correct[:, m] = confusion[:, m][:, np.arange(C), np.arange(C)]
    return StudyOutcome(correct=correct.reshape(S, P, 2, C),
                        answers=confusion.reshape(S, P, 2, C, C),
                        groups=np.array(groups), repetitions=repetitions,
                        roughness_um=pool.roughness_um)

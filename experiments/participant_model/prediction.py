"""Expected proportions correct of the simulated participants, by Monte Carlo, without sessions.

:func:`predicted_cell_probabilities` draws persons (:func:`.person.draw_person`), computes their
noise-free features of every sample from the physics (real contact, or the group's target
profile replayed by a display that tracks it perfectly), and estimates each person's probability
of a correct answer per group x mode x sample from many replicates of familiarisation and test
(the ``absolute`` observer of :class:`.person.SimulatedPerson`, vectorised).
"""
from __future__ import annotations

import math

import numpy as np

from stimuli.paper import (DERMIS_FRACTION_RANGE, GROUP_TARGET_THICKNESS_UM, GROUP_THICKNESS_UM,
                          PAD_MATERIAL, PAD_ROUGHNESS_M, SAMPLE_MATERIAL, SAMPLE_ROUGHNESS_UM,
                          SKIN_TEMPERATURE_RANGE_C, TARGET_SIDES, TARGET_SKIN_TEMPERATURE_C)

from .person import PerceptionParameters, SimulatedPerson, draw_person

__all__ = ["predicted_cell_probabilities"]


def _person_features(person: SimulatedPerson, mode: str, roughness_um, target_thickness_um: float,
                     target_options: dict, target_side: str = "material",
                     pad: tuple[float, str] | None = (PAD_ROUGHNESS_M, PAD_MATERIAL)) -> np.ndarray:
    """Noise-free features, one row per roughness, for ``mode`` "real" or "simulated".

    Simulated: the target profile for a skin of ``target_thickness_um`` (the session's
    ``_target_profile``), tracked perfectly by the pad, felt through the person's own finger–pad
    resistance (``pad`` = (R_a in m, material); ``None``: imposed on the skin directly).
    """
    from stimuli import Skin, target_profile
    rows = []
    for ra in roughness_um:
        if mode == "real":
            t, rec = person.feel_real(ra * 1e-6)
        elif mode == "simulated":
            opts = {"material": SAMPLE_MATERIAL,
                    "skin_temperature": TARGET_SKIN_TEMPERATURE_C,
                    "material_temperature": person.params.material_temperature_C,
                    "duration": person.params.duration_s,
                    "rate": person.params.sample_rate_Hz,
                    "sample_thickness": person.params.sample_thickness_m, **target_options}
            L = target_thickness_um * 1e-6
            skin = Skin(L, dermis=0.6 * L)
            own = None
            if pad is not None:
                from stimuli import contact_resistance, material
                pad_R = float(contact_resistance(pad[0], skin=skin, material=material(pad[1])))
                own = person.pad_resistance(*pad)
            else:
                pad_R = None
            prof = target_profile(roughness=ra * 1e-6, skin=skin, side=target_side,
                                  pad_resistance=pad_R, **opts)
            t, rec = person.feel_imposed(prof.times, prof.temperature, pad_resistance=own)
        else:
            raise ValueError(f"predicted_cell_probabilities: modes: expected 'real' or "
                             f"'simulated', got {mode!r}")
        rows.append(person.features(t, rec))
    return np.array(rows)


def _monte_carlo_correct(params: PerceptionParameters, fam: np.ndarray, test: np.ndarray,
                         familiarise_reps: int, n_reps: int, rng: np.random.Generator) -> np.ndarray:
    """P(correct) per class for one person: ``n_reps`` replicates of familiarisation + test.

    ``fam`` and ``test`` are (classes, features) noise-free features. Vectorised version of
    :meth:`SimulatedPerson.learn`, :meth:`~SimulatedPerson.perceive` and
    :meth:`~SimulatedPerson.decide` (same model, same noise).
    """
    n_cls, n_feat = fam.shape
    sd_fam = params.noise_sd(fam)
    draws = fam + rng.standard_normal((n_reps, familiarise_reps, n_cls, n_feat)) * sd_fam
    templates = draws.mean(axis=1)                                   # (R, C, F)
    var = params.noise_sd(templates) ** 2 * (1.0 + 1.0 / familiarise_reps)
    percepts = test + rng.standard_normal((n_reps, n_cls, n_feat)) * params.noise_sd(test)
    diff = percepts[:, :, None, :] - templates[:, None, :, :]         # (R, true, template, F)
    ll = -0.5 * np.sum(diff ** 2 / var[:, None] + np.log(2 * np.pi * var[:, None]), axis=-1)
    choice = np.argmax(ll, axis=-1)                                  # (R, true)
    lapse = rng.random((n_reps, n_cls)) < params.lapse_rate
    choice = np.where(lapse, rng.integers(0, n_cls, (n_reps, n_cls)), choice)
    return (choice == np.arange(n_cls)).mean(axis=0)


def predicted_cell_probabilities(*, groups: dict | None = None, modes=("real", "simulated"),
                                 roughness_um=SAMPLE_ROUGHNESS_UM, n_people: int = 15,
                                 n_reps: int = 400, familiarise_reps: int = 1,
                                 familiarise_mode: str = "real",
                                 target_thickness_um: dict | None = None,
                                 target_options: dict | None = None,
                                 target_side: str = "material",
                                 pad: tuple[float, str] | None = (PAD_ROUGHNESS_M, PAD_MATERIAL),
                                 skin_temperature_C: tuple[float, float] = SKIN_TEMPERATURE_RANGE_C,
                                 dermis_fraction: tuple[float, float] = DERMIS_FRACTION_RANGE,
                                 params: PerceptionParameters | None = None,
                                 seed: int = 0):
    """Probability of a correct answer per group x mode x roughness, by Monte Carlo.

    For each group, ``n_people`` persons are drawn (:func:`draw_person`); for each, the
    noise-free features of every sample are computed from the physics (real: contact through
    Eq. 5's resistance; simulated: the group's target profile imposed on the person's skin,
    i.e. a display that tracks perfectly); then ``n_reps`` replicates of familiarisation
    (``familiarise_reps`` presentations per sample, in ``familiarise_mode``) and one test
    presentation per sample give the person's probabilities, averaged over persons.

    Parameters
    ----------
    groups : dict, optional
        group -> (low, high) skin thickness, µm. Default :data:`stimuli.paper.GROUP_THICKNESS_UM`.
    modes : sequence of {"real", "simulated"}
    roughness_um : sequence of float, µm
        The samples, roughness_id 1, 2, ... in this order.
    n_people, n_reps, familiarise_reps : int
    familiarise_mode : {"real", "simulated", "same"}
        What the familiarisation presentations are ("same": each mode's own stimuli, i.e. a
        protocol that also familiarises on the display). ``roughness_recognition.toml``
        familiarises on the real samples only.
    target_thickness_um : dict, optional
        group -> skin thickness the simulated profiles are computed for, µm. Default
        650 µm for A and 1000 µm for B (§3.2), else the middle of the group's range.
    target_options : dict, optional
        Keyword arguments for :func:`stimuli.target_profile` overriding the defaults
        (steel of ``params.sample_thickness_m``, skin at
        :data:`stimuli.paper.TARGET_SKIN_TEMPERATURE_C`,
        material at ``params.material_temperature_C``, ``params.duration_s`` at
        ``params.sample_rate_Hz``; as the session computes them from the protocol), e.g.
        ``method`` or ``resolution``.
    skin_temperature_C, dermis_fraction : (low, high)
        Ranges the persons are drawn from (:func:`draw_person`), °C and a share.
    target_side : {"material", "skin", "compensated"}
        Which temperature the display replays (:func:`stimuli.target_profile` ``side``):
        ``"material"`` is the paper's Eq. 7 (the protocol's default); ``"skin"`` the skin side
        of the same contact; ``"compensated"`` the pad temperature that, through the finger–pad
        resistance, reproduces the real contact for a skin of the target's thickness.
    pad : (float, str) or None
        The pad's face, (R_a in m, material): the target's pad resistance and each person's own
        finger–pad resistance (Eq. 5; default 0.4 µm copper, as the emulator and the protocol).
        ``None``: the pad temperature is imposed on the skin directly (no contact resistance).
    params : PerceptionParameters
    seed : int

    Returns
    -------
    pandas.DataFrame
        Columns group, mode, roughness_id, roughness_um, p_correct, se (Monte Carlo standard
        error over persons), n_people.

    Notes
    -----
    The trial-to-trial skin temperature jitter (``skin_temperature_sd_C``, 0.1 K against a
    ~15 K skin-sample difference) is left out of the prediction.
    """
    import pandas as pd   # heavy: only for the returned table

    groups = dict(GROUP_THICKNESS_UM if groups is None else groups)
    params = params or PerceptionParameters()
    target_thickness_um = dict(target_thickness_um or {})
    for g, (lo, hi) in groups.items():
        target_thickness_um.setdefault(g, GROUP_TARGET_THICKNESS_UM.get(g, 0.5 * (lo + hi)))
    target_options = dict(target_options or {})
    rng = np.random.default_rng(seed)
    if familiarise_mode not in ("real", "simulated", "same"):
        raise ValueError(f"predicted_cell_probabilities: familiarise_mode: expected 'real', "
                         f"'simulated' or 'same', got {familiarise_mode!r}")
    if target_side not in TARGET_SIDES:
        raise ValueError(f"predicted_cell_probabilities: target_side: expected one of "
                         f"{', '.join(TARGET_SIDES)}, got {target_side!r}")
    needed = set(modes) | ({familiarise_mode} - {"same"})
    rows = []
    for g, rng_um in groups.items():
        per_person = {m: [] for m in modes}
        for _ in range(int(n_people)):
            person = draw_person(thickness_um=rng_um, rng=rng, params=params,
                                 skin_temperature_C=skin_temperature_C,
                                 dermis_fraction=dermis_fraction)
            feats = {m: _person_features(person, m, roughness_um, target_thickness_um[g],
                                         target_options, target_side, pad) for m in needed}
            for m in modes:
                fam = feats[m if familiarise_mode == "same" else familiarise_mode]
                per_person[m].append(_monte_carlo_correct(params, fam, feats[m],
                                                          int(familiarise_reps), int(n_reps), rng))
        for m in modes:
            p = np.array(per_person[m])                                # (people, classes)
            for i, ra in enumerate(roughness_um):
                se = p[:, i].std(ddof=1) / math.sqrt(len(p)) if len(p) > 1 else float("nan")
                rows.append({"group": g, "mode": m, "roughness_id": i + 1, "roughness_um": float(ra),
                             "p_correct": float(p[:, i].mean()), "se": float(se),
                             "n_people": len(p)})
    return pd.DataFrame(rows)

"""Every (replay hypothesis x observer) scenario against the paper's claims, and the sensitivity
of the headline to the model's deciding choices.

:func:`evaluate_scenarios` simulates many 15 + 15 studies per scenario
(:func:`..studies.simulate_studies`) and returns, per scenario, the probability that a study
shows each claim of :data:`analysis.claims.CLAIMS` (with its 95 % Monte-Carlo interval) and the
expected proportions correct.  :func:`best_scenario` picks the scenario that best matches the
paper's evidence: the highest probability that one study shows every claim at once.
:func:`sensitivity` re-runs one scenario with one choice changed at a time.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from stimuli.paper import (PAD_MATERIAL, PAD_ROUGHNESS_M, REPLAY_NAMES, SAMPLE_MATERIAL,
                          TABLE2_ROUGHNESS_UM)

__all__ = ["ScenarioResult", "evaluate_scenarios", "best_scenario", "table2_replay_temperatures",
           "sensitivity", "SENSITIVITY_CHOICES", "tied_scenarios", "ABSOLUTE_RECEPTOR_DEPTH_UM"]

#: One receptor depth below the surface for everyone, µm: 0.4 x 860 µm, the middle of the
#: model's 0.35-0.45 L at the mean thickness of the two groups' ranges (675 and 1050 µm).
ABSOLUTE_RECEPTOR_DEPTH_UM = 345.0


@dataclass
class ScenarioResult:
    """Claims and expected proportions of every scenario.

    Attributes
    ----------
    claims : pandas.DataFrame
        One row per (hypothesis, observer, claim): probability, mc_low, mc_high, n_studies,
        mean_statistic.
    proportions : pandas.DataFrame
        One row per (hypothesis, observer, group, mode, roughness_id): expected proportion
        correct (mean over studies) and the 2.5 / 97.5 % quantiles of a single study's.
    settings : dict
    """

    claims: pd.DataFrame
    proportions: pd.DataFrame
    settings: dict = field(default_factory=dict)

    def wide(self) -> pd.DataFrame:
        """Scenario rows, claim columns: probabilities."""
        return self.claims.pivot_table(index=["hypothesis", "observer"], columns="claim",
                                       values="probability", sort=False)


def table2_replay_temperatures(hypothesis: str, roughness_um=TABLE2_ROUGHNESS_UM) -> np.ndarray:
    """What the display would replay at 20 s under Table 2's conditions, °C, per roughness.

    Table 2 (Exp. 1): skin 35 °C, steel 24 °C, read at 20 s; skin 650 µm (dermis 0.6 L), the
    the hypothesis's formula and material (the 3 mm steel or a half-space), Eq. 5 contact resistance, the 0.4 µm copper pad for the compensated
    replay.  No display rounding.
    """
    from experiments.simulation.replay import replay_hypothesis
    from stimuli import Skin, contact_resistance, material, target_profile
    hyp = replay_hypothesis(hypothesis)
    skin = Skin(650e-6, dermis=0.6 * 650e-6)
    pad_r = float(contact_resistance(PAD_ROUGHNESS_M, skin=skin, material=material(PAD_MATERIAL)))
    out = []
    for ra in roughness_um:
        steel = material(SAMPLE_MATERIAL,
                         thickness=None if hyp.replayed_material == "half-space" else 3e-3)
        prof = target_profile(material=steel, roughness=ra * 1e-6, skin=skin,
                              skin_temperature=35.0, material_temperature=24.0, duration=20.0,
                              rate=10.0, resolution=1e-6, side=hyp.target_side,
                              method=hyp.method, pad_resistance=pad_r, cache=False)
        out.append(float(prof.temperature[-1]))
    return np.array(out)


def _proportion_rows(outcome, keys: dict) -> list:
    rows = []
    from experiments.simulation.studies import GROUPS
    for gi, g in enumerate(GROUPS):
        sel = outcome.correct[:, outcome.groups == g] / outcome.repetitions     # (S, n, 2, C)
        per_study = sel.mean(axis=1)                                            # (S, 2, C)
        for m, mode in enumerate(("real", "simulated")):
            for c in range(per_study.shape[-1]):
                v = per_study[:, m, c]
                rows.append({**keys, "group": g, "mode": mode, "roughness_id": c + 1,
                             "roughness_um": float(outcome.roughness_um[c]) if outcome.roughness_um else np.nan,
                             "expected": float(v.mean()), "study_low": float(np.quantile(v, 0.025)),
                             "study_high": float(np.quantile(v, 0.975))})
    return rows


def evaluate_scenarios(pool, hypotheses=None, observers=None, n_studies: int = 400,
                       n_per_group: int = 15, familiarise_reps: int = 1, params=None,
                       seed: int = 0) -> ScenarioResult:
    """Claims and expected proportions for every (hypothesis x observer) scenario.

    Parameters
    ----------
    pool : PersonPool
        From :func:`..studies.build_pool` (its hypotheses are the default).
    hypotheses, observers : sequence of str, optional
        Default: the pool's hypotheses, every observer of :data:`..observers.OBSERVERS`.
    n_studies, n_per_group, familiarise_reps : int
    params : PerceptionParameters, optional
    seed : int
    """
    from analysis.claims import claim_probabilities, evaluate_claims
    from experiments.simulation.observers import OBSERVERS, get_observer
    from experiments.simulation.studies import simulate_studies
    hypotheses = list(hypotheses or sorted({h for h, _ in pool.simulated},
                                           key=REPLAY_NAMES.index))
    observers = list(observers or OBSERVERS)
    claim_rows, prop_rows = [], []
    for hi, h in enumerate(hypotheses):
        temps = table2_replay_temperatures(h)
        for oi, name in enumerate(observers):
            outcome = simulate_studies(pool, h, get_observer(name), n_studies=n_studies,
                                       n_per_group=n_per_group, familiarise_reps=familiarise_reps,
                                       params=params, seed=int(seed) * 1000 + 10 * hi + oi)
            verdicts = evaluate_claims(outcome.correct, outcome.groups, outcome.repetitions, temps,
                                       answered=outcome.answers.sum(axis=-2))
            table = claim_probabilities(verdicts)
            table.insert(0, "observer", name)
            table.insert(0, "hypothesis", h)
            claim_rows.append(table)
            prop_rows += _proportion_rows(outcome, {"hypothesis": h, "observer": name})
    return ScenarioResult(claims=pd.concat(claim_rows, ignore_index=True),
                          proportions=pd.DataFrame(prop_rows),
                          settings={"n_studies": int(n_studies), "n_per_group": int(n_per_group),
                                    "familiarise_reps": int(familiarise_reps), "seed": int(seed),
                                    **pool.settings})


def best_scenario(result: ScenarioResult) -> tuple[str, str]:
    """``(hypothesis, observer)`` that best matches the paper's evidence.

    The paper reports one study in which every claim held: the scenario under which a study
    shows all of them at once most often (claim ``all``) matches it best; ties (to two decimals)
    go to the higher mean probability over the single claims, then to the earlier row
    (hypotheses material, skin, compensated; observers in :data:`..observers.OBSERVERS` order).
    """
    wide = result.wide()
    single = wide.drop(columns=["all"], errors="ignore").mean(axis=1)
    score = pd.DataFrame({"all": wide["all"].round(2), "mean": single})
    order = score.sort_values(["all", "mean"], ascending=False, kind="stable")
    return tuple(order.index[0])


def tied_scenarios(result: ScenarioResult, best) -> list:
    """Scenarios other than ``best`` tied with it on :func:`best_scenario`'s first key.

    That is the probability of showing every claim in one study, rounded to two decimals;
    among them the choice went to the higher mean probability of the single claims.
    """
    wide = result.wide()
    if "all" not in wide.columns:
        return []
    key = wide["all"].round(2)
    return [k for k in wide.index if k != tuple(best) and key.loc[k] == key.loc[tuple(best)]]


#: Choices the headline depends on, each with its alternatives (label -> keyword changes).
SENSITIVITY_CHOICES = {
    "receptor depth": {
        "0.35-0.45 L below the surface (model default)": {},
        f"{ABSOLUTE_RECEPTOR_DEPTH_UM:g} µm below the surface for all": {
            "receptor_depth_um": ABSOLUTE_RECEPTOR_DEPTH_UM},
    },
    "noise floor": {
        "0.15 K, 0.15 K/s": {"noise": 0.15},
        "0.3 K, 0.3 K/s (default)": {},
        "0.6 K, 0.6 K/s": {"noise": 0.6},
    },
    "familiarisation touches": {
        "1 per sample (the paper)": {},
        "3 per sample": {"familiarise_reps": 3},
    },
}


def sensitivity(pool, hypothesis: str, observer: str, n_studies: int = 400, seed: int = 0,
                protocol="roughness_recognition", depth_pool=None) -> pd.DataFrame:
    """The headline scenario with one choice changed at a time (:data:`SENSITIVITY_CHOICES`).

    Returns
    -------
    pandas.DataFrame
        One row per (choice, setting): the claims' probabilities and the expected proportion
        correct, real and simulated, per group (mean over samples).
    """
    from analysis.claims import claim_probabilities, evaluate_claims
    from experiments.simulation.observers import get_observer
    from experiments.simulation.studies import build_pool, simulate_studies
    rows = []
    temps = table2_replay_temperatures(hypothesis)
    for choice, settings in SENSITIVITY_CHOICES.items():
        for label, change in settings.items():
            use_pool, params, fam = pool, pool.params, 1
            if "receptor_depth_um" in change:
                use_pool = depth_pool or build_pool(protocol, hypotheses=(hypothesis,),
                                                    pool_size=pool.settings["pool_size"],
                                                    seed=pool.settings["seed"], params=pool.params,
                                                    receptor_depth_um=change["receptor_depth_um"])
            if "noise" in change:
                params = dataclasses.replace(params, drop_noise_C=change["noise"],
                                             rate_noise_C_per_s=change["noise"])
            fam = change.get("familiarise_reps", 1)
            out = simulate_studies(use_pool, hypothesis, get_observer(observer), n_studies=n_studies,
                                   familiarise_reps=fam, params=params, seed=seed)
            probs = claim_probabilities(evaluate_claims(out.correct, out.groups, out.repetitions, temps,
                                                        answered=out.answers.sum(axis=-2)))
            row = {"choice": choice, "setting": label}
            row.update({r.claim: r.probability for r in probs.itertuples()})
            p = out.proportions()                           # (groups, modes, C)
            for gi, g in enumerate(("A", "B")):
                row[f"p_real_{g}"] = float(p[gi, 0].mean())
                row[f"p_sim_{g}"] = float(p[gi, 1].mean())
            rows.append(row)
    return pd.DataFrame(rows)

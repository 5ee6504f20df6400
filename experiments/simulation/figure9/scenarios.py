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
        One row per (hypothesis, observer, reading, claim): probability, mc_low, mc_high,
        n_studies, mean_statistic.
    proportions : pandas.DataFrame
        One row per (hypothesis, observer, group, mode, roughness_id): expected proportion
        correct (mean over studies) and a single study's quantiles: study_low / study_high
        (2.5 / 97.5 %), study_q25 / study_q75, study_median.
    settings : dict
    """

    claims: pd.DataFrame
    proportions: pd.DataFrame
    settings: dict = field(default_factory=dict)

    def wide(self, reading: str = "descriptive") -> pd.DataFrame:
        """Scenario rows, claim columns: probabilities in one reading."""
        sel = self.claims[self.claims["reading"] == reading] if "reading" in self.claims else self.claims
        return sel.pivot_table(index=["hypothesis", "observer"], columns="claim",
                               values="probability", sort=False)


def table2_replay_temperatures(hypothesis: str, roughness_um=TABLE2_ROUGHNESS_UM,
                               decisions: list | None = None) -> np.ndarray:
    """What the display would replay at 20 s under Table 2's conditions, °C, per roughness.

    Table 2 (Exp. 1): skin 35 °C, steel 24 °C, read at 20 s; skin 650 µm (dermis 0.6 L), the
    the hypothesis's formula and material (the 3 mm steel or a half-space), Eq. 5 contact resistance, the 0.4 µm copper pad for the compensated
    replay.  No display rounding.  Each profile is :func:`stimuli.target_profile`'s (the exact
    ones planned to half of the 1e-6 K resolution); ``decisions``: a list each profile's recorded
    plan (``parameters["plan"]``) is appended to.
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
        if decisions is not None:
            decisions.append(prof.parameters["plan"])
    return np.array(out)


def replay_models(plans: list) -> list:
    """Distinct models of recorded profile plans: ``[{model, method, tolerance_K, max_bound_K,
    count}]`` (a plan of two sides counts each side)."""
    out = {}
    for plan in plans:
        for p in plan.get("sides") or [plan]:
            e = out.setdefault(p.get("model"), {"model": p.get("model"), "method": p.get("method"),
                                                "tolerance_K": p.get("tolerance_K"),
                                                "max_bound_K": 0.0, "count": 0})
            e["count"] += 1
            e["max_bound_K"] = max(e["max_bound_K"], float(p.get("bound_K") or 0.0))
    return list(out.values())


def _proportion_rows(per_study, roughness_um, keys: dict) -> list:
    """Rows of :attr:`ScenarioResult.proportions` from per-study proportions (S, groups, 2, C)."""
    from experiments.simulation.studies import GROUPS
    rows = []
    for gi, g in enumerate(GROUPS):
        for m, mode in enumerate(("real", "simulated")):
            for c in range(per_study.shape[-1]):
                v = per_study[:, gi, m, c]
                q = np.quantile(v, [0.025, 0.25, 0.5, 0.75, 0.975])
                rows.append({**keys, "group": g, "mode": mode, "roughness_id": c + 1,
                             "roughness_um": float(roughness_um[c]) if roughness_um else np.nan,
                             "expected": float(v.mean()), "study_low": float(q[0]),
                             "study_q25": float(q[1]), "study_median": float(q[2]),
                             "study_q75": float(q[3]), "study_high": float(q[4])})
    return rows


def study_task(pool, hypothesis: str, observer: str, n_studies: int, n_per_group: int,
               familiarise_reps: int, params, seed, temps, variability=None) -> dict:
    """One task of a sweep: ``n_studies`` studies of one scenario, reduced to what tables need.

    Returns
    -------
    dict
        ``readings``: :func:`analysis.claims.evaluate_readings` of the studies;
        ``proportions``: per-study proportion correct, shape (S, groups, 2 modes, C).
    """
    from analysis.claims import evaluate_readings
    from experiments.participant_model.observers import get_observer
    from experiments.simulation.studies import GROUPS, simulate_studies
    out = simulate_studies(pool, hypothesis, get_observer(observer), n_studies=n_studies,
                           n_per_group=n_per_group, familiarise_reps=familiarise_reps,
                           params=params, seed=seed, variability=variability)
    readings = evaluate_readings(out.correct, out.groups, out.repetitions, temps,
                                 answered=out.answers.sum(axis=-2))
    props = np.stack([out.correct[:, out.groups == g].mean(axis=1) / out.repetitions
                      for g in GROUPS], axis=1)
    return {"readings": readings, "proportions": props}


def _merge(parts: list) -> dict:
    """The tasks of one scenario joined along the study axis."""
    readings = {r: {cid: tuple(np.concatenate([p["readings"][r][cid][k] for p in parts])
                               for k in (0, 1))
                    for cid in parts[0]["readings"][r]}
                for r in parts[0]["readings"]}
    return {"readings": readings,
            "proportions": np.concatenate([p["proportions"] for p in parts])}


def _claim_rows(readings: dict, keys: dict) -> list:
    from analysis.claims import claim_probabilities
    tables = []
    for reading, verdicts in readings.items():
        table = claim_probabilities(verdicts)
        for i, (k, v) in enumerate({**keys, "reading": reading}.items()):
            table.insert(i, k, v)
        tables.append(table)
    return tables


def run_scenarios(pool, scenarios, n_studies: int, *, n_per_group: int = 15,
                  seed: int = 0, sweep=None, decisions: dict | None = None) -> list:
    """Simulate every scenario's studies (on ``sweep`` if given, else here), merged per scenario.

    Parameters
    ----------
    scenarios : list of dict
        Each: ``hypothesis``, ``observer``, ``tag`` (int, part of the seed), optional
        ``familiarise_reps``, ``params``, ``pool``, ``variability``.
    sweep : :class:`..sweep.Sweep`, optional
    decisions : dict, optional
        Filled with each hypothesis's Table 2 replay profiles' recorded plans (the "T2 rise"
        claim's temperatures, :func:`table2_replay_temperatures`).

    Returns
    -------
    list of dict
        Per scenario: ``readings`` and ``proportions`` (see :func:`study_task`).
    """
    from experiments.simulation.sweep import chunks
    sizes = chunks(n_studies)
    temps = {}
    tasks, owner, weights = [], [], []
    pools = {}
    for si, sc in enumerate(scenarios):
        h = sc["hypothesis"]
        if h not in temps:
            plans = [] if decisions is None else decisions.setdefault(h, [])
            temps[h] = table2_replay_temperatures(h, decisions=plans)
        use_pool = sc.get("pool", pool)
        key = id(use_pool)
        if key not in pools:
            pools[key] = sweep.scatter(use_pool) if sweep is not None else use_pool
        for ci, size in enumerate(sizes):
            tasks.append((pools[key], h, sc["observer"], size, n_per_group,
                          sc.get("familiarise_reps", 1), sc.get("params"),
                          (int(seed), int(sc["tag"]), ci), temps[h], sc.get("variability")))
            owner.append(si)
            weights.append(size)
    if sweep is not None:
        parts = sweep.map(study_task, tasks, what="simulated studies", weights=weights)
    else:
        parts = [study_task(*t) for t in tasks]
    return [_merge([p for p, o in zip(parts, owner) if o == si]) for si in range(len(scenarios))]


def evaluate_scenarios(pool, hypotheses=None, observers=None, n_studies: int = 400,
                       n_per_group: int = 15, familiarise_reps: int = 1, params=None,
                       seed: int = 0, sweep=None, variability=None) -> ScenarioResult:
    """Claims (both readings) and expected proportions for every (hypothesis x observer) scenario.

    Parameters
    ----------
    pool : PersonPool
        From :func:`..studies.build_pool` (its hypotheses are the default).
    hypotheses, observers : sequence of str, optional
        Default: the pool's hypotheses, every observer of :data:`..observers.OBSERVERS`.
    n_studies, n_per_group, familiarise_reps : int
    params : PerceptionParameters, optional
    seed : int
    sweep : :class:`..sweep.Sweep`, optional
        Where the studies run (default: here, one after the other; same results).
    variability : LabVariability, optional
        :class:`..studies.LabVariability` of every study (default: none).
    """
    from experiments.participant_model.observers import OBSERVERS
    hypotheses = list(hypotheses or sorted({h for h, _ in pool.simulated},
                                           key=REPLAY_NAMES.index))
    observers = list(observers or OBSERVERS)
    scenarios = [{"hypothesis": h, "observer": o, "tag": 100 * hi + oi,
                  "familiarise_reps": familiarise_reps, "params": params,
                  "variability": variability}
                 for hi, h in enumerate(hypotheses) for oi, o in enumerate(observers)]
    table2_plans = {}
    merged = run_scenarios(pool, scenarios, n_studies, n_per_group=n_per_group, seed=seed,
                           sweep=sweep, decisions=table2_plans)
    claim_rows, prop_rows = [], []
    for sc, res in zip(scenarios, merged):
        keys = {"hypothesis": sc["hypothesis"], "observer": sc["observer"]}
        claim_rows += _claim_rows(res["readings"], keys)
        prop_rows += _proportion_rows(res["proportions"], pool.roughness_um, keys)
    return ScenarioResult(claims=pd.concat(claim_rows, ignore_index=True),
                          proportions=pd.DataFrame(prop_rows),
                          settings={"n_studies": int(n_studies), "n_per_group": int(n_per_group),
                                    "familiarise_reps": int(familiarise_reps), "seed": int(seed),
                                    "table2_replay_models": {h: replay_models(v) for h, v
                                                             in table2_plans.items()},
                                    **pool.settings})


def best_scenario(result: ScenarioResult, reading: str = "descriptive") -> tuple[str, str]:
    """``(hypothesis, observer)`` that best matches the paper's evidence in one reading.

    The paper reports one study in which every claim held: the scenario under which a study
    shows all of them at once most often (claim ``all``) matches it best; ties (to two decimals)
    go to the higher mean probability over the single claims, then to the earlier row
    (hypotheses in :data:`stimuli.paper.REPLAY_NAMES` order; observers in
    :data:`..observers.OBSERVERS` order).
    """
    wide = result.wide(reading)
    single = wide.drop(columns=["all"], errors="ignore").mean(axis=1)
    score = pd.DataFrame({"all": wide["all"].round(2), "mean": single})
    order = score.sort_values(["all", "mean"], ascending=False, kind="stable")
    return tuple(order.index[0])


def tied_scenarios(result: ScenarioResult, best, reading: str = "descriptive") -> list:
    """Scenarios other than ``best`` tied with it on :func:`best_scenario`'s first key.

    That is the probability of showing every claim in one study, rounded to two decimals;
    among them the choice went to the higher mean probability of the single claims.
    """
    wide = result.wide(reading)
    if "all" not in wide.columns:
        return []
    key = wide["all"].round(2)
    return [k for k in wide.index if k != tuple(best) and key.loc[k] == key.loc[tuple(best)]]


#: Choices the headline depends on, each with its alternatives (label -> changes).  Keys of a
#: change: ``receptor_depth_um`` / ``sensor_tau_s`` (a pool built for it), ``noise``,
#: ``familiarise_reps``, ``lab`` (:class:`..studies.LabVariability` fields).  The first
#: setting of each choice marked "(default)" is the headline's own.
SENSITIVITY_CHOICES = {
    "receptor depth": {
        "0.35-0.45 L below the surface (default)": {},
        f"{ABSOLUTE_RECEPTOR_DEPTH_UM:g} µm below the surface for all": {
            "receptor_depth_um": ABSOLUTE_RECEPTOR_DEPTH_UM},
    },
    "noise floor": {
        "0.15 K, 0.15 K/s": {"noise": 0.15},
        "0.3 K, 0.3 K/s (default)": {},
        "0.6 K, 0.6 K/s": {"noise": 0.6},
    },
    "familiarisation touches": {
        "1 per sample (the paper; default)": {},
        "3 per sample": {"familiarise_reps": 3},
    },
    "contact force per touch": {
        "2 N every touch": {"lab": {"force_sd_N": 0.0}},
        "2 ± 0.25 N (default)": {},
        "2 ± 0.5 N": {"lab": {"force_sd_N": 0.5}},
    },
    "pad sensor lag": {
        "none (default)": {},
        "0.1 s": {"sensor_tau_s": 0.1},
        "0.3 s": {"sensor_tau_s": 0.3},
    },
    "skin temperature within participant": {
        "none": {"lab": {"skin_temperature_sd_C": 0.0}},
        "0.1 K per touch (default)": {},
        "0.3 K per touch": {"lab": {"skin_temperature_sd_C": 0.3}},
    },
    "skin temperature between participants": {
        "35.5-36 °C (the paper; default)": {},
        "34.5-36.5 °C": {"lab": {"skin_temperature_C": (34.5, 36.5)}},
    },
    "cohort": {
        "fresh per study (default)": {},
        "one cohort of 100 per group, reused": {"lab": {"cohort_size": 100}},
    },
}


def _build_pool_task(protocol, kwargs):
    """:func:`..studies.build_pool` as a sweep task."""
    from experiments.simulation.studies import build_pool
    return build_pool(protocol, **kwargs)


def sensitivity(pool, hypothesis: str, observer: str, n_studies: int = 400, seed: int = 0,
                protocol="roughness_recognition", sweep=None, variability=None,
                extra_pools: dict | None = None, choices=None) -> pd.DataFrame:
    """The headline scenario with one choice changed at a time (:data:`SENSITIVITY_CHOICES`).

    Parameters
    ----------
    extra_pools : dict, optional
        ``(key, value) -> PersonPool`` already built for a pool-changing setting (e.g. a fitted
        receptor depth), used instead of building it.
    choices : dict, optional
        Default :data:`SENSITIVITY_CHOICES`.

    Returns
    -------
    pandas.DataFrame
        One row per (choice, setting): the claims' probabilities in both readings
        (``<claim>`` descriptive, ``<claim>_inf`` inferential) and the expected proportion
        correct, real and simulated, per group (mean over samples).
    """
    import dataclasses as dc
    from experiments.simulation.studies import DEFAULT_LAB, GROUPS
    base_lab = variability or DEFAULT_LAB
    extra_pools = dict(extra_pools or {})
    choices = SENSITIVITY_CHOICES if choices is None else choices
    # the pools the settings need, built first (on the sweep's workers when there is one)
    wanted = {}
    for settings in choices.values():
        for change in settings.values():
            for key in ("receptor_depth_um", "sensor_tau_s"):
                k = (key, change.get(key))
                if key in change and k not in extra_pools and k not in wanted:
                    same_people = ({"receptor_depth_um": pool.receptor_depth_um,
                                    "real_from": pool} if key == "sensor_tau_s" else {})
                    wanted[k] = {"hypotheses": (hypothesis,), "seed": pool.settings["seed"],
                                 "params": pool.params,
                                 "dermis_fraction": pool.settings["dermis_fraction"],
                                 key: change[key], **same_people}
    if wanted:
        jobs = [(protocol, kw) for kw in wanted.values()]
        built = (sweep.map(_build_pool_task, jobs, what="person pools") if sweep is not None
                 else [_build_pool_task(*job) for job in jobs])
        extra_pools.update(zip(wanted, built))
    scenarios, labels = [], []
    for ci, (choice, settings) in enumerate(choices.items()):
        for si, (label, change) in enumerate(settings.items()):
            use_pool, params, lab = change.get("pool", pool), pool.params, base_lab
            for key in ("receptor_depth_um", "sensor_tau_s"):
                if key in change:
                    use_pool = extra_pools[(key, change[key])]
            if "noise" in change:
                params = dc.replace(params, drop_noise_C=change["noise"],
                                    rate_noise_C_per_s=change["noise"])
            if "lab" in change:
                lab = dc.replace(lab, **change["lab"])
            scenarios.append({"hypothesis": hypothesis, "observer": observer, "pool": use_pool,
                              "tag": 10_000 + 100 * ci + si, "params": params,
                              "familiarise_reps": change.get("familiarise_reps", 1),
                              "variability": lab})
            labels.append((choice, label))
    merged = run_scenarios(pool, scenarios, n_studies, seed=seed, sweep=sweep)
    rows = []
    for (choice, label), res in zip(labels, merged):
        row = {"choice": choice, "setting": label}
        for reading, suffix in (("descriptive", ""), ("inferential", "_inf")):
            for r in _claim_rows({reading: res["readings"][reading]}, {})[0].itertuples():
                row[r.claim + suffix] = r.probability
        p = res["proportions"].mean(axis=0)                         # (groups, modes, C)
        for gi, g in enumerate(GROUPS):
            row[f"p_real_{g}"] = float(p[gi, 0].mean())
            row[f"p_sim_{g}"] = float(p[gi, 1].mean())
        rows.append(row)
    return pd.DataFrame(rows)

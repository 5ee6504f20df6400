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

# the workers' tasks live in a module without pandas or analysis (see .tasks)
from .tasks import build_pool_task, claims_of_studies, study_task

__all__ = ["ScenarioResult", "StudyRuns", "evaluate_scenarios", "best_scenario",
           "table2_replay_temperatures", "sensitivity", "SENSITIVITY_CHOICES", "tied_scenarios", "ABSOLUTE_RECEPTOR_DEPTH_UM",
           "result_from_runs", "sensitivity_row", "mark_differences", "run_scenarios",
           "build_pool_task", "study_task"]

#: One receptor depth below the surface for everyone, µm: 0.4 x 860 µm, the middle of the
#: model's 0.35-0.45 L at the mean thickness of the two groups' ranges (675 and 1050 µm).
ABSOLUTE_RECEPTOR_DEPTH_UM = 345.0


@dataclass
class ScenarioResult:
    """Claims and expected proportions of every scenario.

    Attributes
    ----------
    claims : pandas.DataFrame
        One row per (hypothesis, observer, reading, claim): probability, mc_low, mc_high (the
        Wilson interval at :data:`.precision.MC_LEVEL`), n_studies, mean_statistic.
    proportions : pandas.DataFrame
        One row per (hypothesis, observer, group, mode, roughness_id): expected proportion
        correct (mean over studies) and a single study's quantiles: study_low / study_high
        (2.5 / 97.5 %), study_q25 / study_q75, study_median.
    settings : dict
    """

    claims: pd.DataFrame
    proportions: pd.DataFrame
    settings: dict = field(default_factory=dict)
    runs: list = field(default_factory=list)
    #: Tables derived from ``claims`` (which is not changed after the result is made).
    cache: dict = field(default_factory=dict, repr=False, compare=False)

    def bounds(self, reading: str = "descriptive") -> tuple:
        """``(low, high)``: the intervals' ends, shaped as :meth:`wide`."""
        key = ("bounds", reading)
        if key not in self.cache:
            sel = self.claims[self.claims["reading"] == reading]
            self.cache[key] = tuple(sel.pivot_table(index=["hypothesis", "observer"],
                                                    columns="claim", values=v, sort=False)
                                    for v in ("mc_low", "mc_high"))
        return self.cache[key]

    def n_studies(self) -> pd.Series:
        """Studies simulated per scenario (sequential: they differ)."""
        if "n_studies" not in self.cache:
            sel = self.claims[self.claims["claim"] == "all"]
            self.cache["n_studies"] = sel.groupby(["hypothesis", "observer"],
                                                  sort=False)["n_studies"].max()
        return self.cache["n_studies"]

    def answer_shares(self, scenario) -> np.ndarray | None:
        """Mean share of the simulated block's answers per class (1# first), or None."""
        for keys, res in self.runs:
            if (keys.get("hypothesis"), keys.get("observer")) == tuple(scenario):
                share = res.get("answer_share")
                return None if share is None else np.nanmean(share, axis=0)
        return None

    def wide(self, reading: str = "descriptive") -> pd.DataFrame:
        """Scenario rows, claim columns: probabilities in one reading."""
        key = ("wide", reading)
        if key not in self.cache:
            sel = (self.claims[self.claims["reading"] == reading] if "reading" in self.claims
                   else self.claims)
            self.cache[key] = sel.pivot_table(index=["hypothesis", "observer"], columns="claim",
                                              values="probability", sort=False)
        return self.cache[key]


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


def _merge(parts: list) -> dict:
    """The tasks of one scenario joined along the study axis."""
    readings = {r: {cid: tuple(np.concatenate([p["readings"][r][cid][k] for p in parts])
                               for k in (0, 1))
                    for cid in parts[0]["readings"][r]}
                for r in parts[0]["readings"]}
    return {"readings": readings,
            "proportions": np.concatenate([p["proportions"] for p in parts]),
            "answer_share": np.concatenate([p["answer_share"] for p in parts])}


def _claim_rows(readings: dict, keys: dict) -> list:
    """Per reading, the claims' probabilities; besides ``all``, ``all_paper``: every claim that
    is the paper's own statement (no ``*``) in the same study."""
    from analysis.claims import CLAIMS, claim_probabilities, wilson_interval
    from experiments.simulation.figure9.precision import MC_LEVEL
    own = {c.id for c in CLAIMS if c.own}
    tables = []
    for reading, verdicts in readings.items():
        table = claim_probabilities(verdicts, MC_LEVEL)
        paper = [h for cid, (_, h) in verdicts.items() if cid not in own]
        joint = np.logical_and.reduce(paper)
        k, n = int(joint.sum()), joint.size
        lo, hi = wilson_interval(k, n, MC_LEVEL)
        table = pd.concat([table, pd.DataFrame([{
            "claim": "all_paper", "probability": k / n, "mc_low": float(lo), "mc_high": float(hi),
            "n_studies": n, "mean_statistic": k / n}])], ignore_index=True)
        for i, (k, v) in enumerate({**keys, "reading": reading}.items()):
            table.insert(i, k, v)
        tables.append(table)
    return tables


def run_scenarios(pool, scenarios, n_studies: int, *, n_per_group: int = 15,
                  seed: int = 0, sweep=None, decisions: dict | None = None,
                  max_studies: int | None = None) -> list:
    """Simulate every scenario's studies (on ``sweep`` if given, else here), merged per scenario.

    With ``max_studies``, studies are added sequentially (:mod:`.precision`): after the first
    ``n_studies``, every scenario still undecided (:func:`.precision.needs_more`) gets as many
    again, until it is decided or has ``max_studies``.  Chunk ``ci`` of a scenario always has
    the seed ``(seed, tag, ci)``: the result does not depend on the workers.

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
        Per scenario: ``readings``, ``proportions`` and ``answer_share`` (see
        :func:`.tasks.study_task` and :func:`.tasks.claims_of_studies`).
    """
    from experiments.simulation.figure9.precision import needs_more, round_sizes
    from experiments.simulation.sweep import chunks
    temps = {}
    pools = {}
    for sc in scenarios:
        h = sc["hypothesis"]
        if h not in temps:
            plans = [] if decisions is None else decisions.setdefault(h, [])
            temps[h] = table2_replay_temperatures(h, decisions=plans)
        use_pool = sc.get("pool", pool)
        if id(use_pool) not in pools:
            pools[id(use_pool)] = sweep.scatter(use_pool) if sweep is not None else use_pool
    parts = {si: [] for si in range(len(scenarios))}
    next_chunk = {si: 0 for si in range(len(scenarios))}
    active = list(range(len(scenarios)))
    rounds = round_sizes(n_studies, max_studies if max_studies is not None else n_studies)
    for size in rounds:
        tasks, owner, weights = [], [], []
        for si in active:
            sc = scenarios[si]
            for chunk in chunks(size):
                ci = next_chunk[si]
                next_chunk[si] += 1
                tasks.append((pools[id(sc.get("pool", pool))], sc["hypothesis"], sc["observer"],
                              chunk, n_per_group, sc.get("familiarise_reps", 1), sc.get("params"),
                              (int(seed), int(sc["tag"]), ci), temps[sc["hypothesis"]],
                              sc.get("variability")))
                owner.append(si)
                weights.append(chunk)
        if sweep is not None:
            done = sweep.map(study_task, tasks, what="simulated studies", weights=weights,
                             then=claims_of_studies)
        else:
            done = [claims_of_studies(study_task(*t)) for t in tasks]
        for si, part in zip(owner, done):
            parts[si].append(part)
        active = [si for si in active if needs_more(_merge(parts[si])["readings"])]
        if not active:
            break
    return [_merge(parts[si]) for si in range(len(scenarios))]


def result_from_runs(runs, roughness_um=(), settings: dict | None = None) -> "ScenarioResult":
    """A :class:`ScenarioResult` from runs ``[(keys, merged result)]`` (simulated, or read back
    from ``studies.csv`` by :func:`.precision.runs_from_table`)."""
    claim_rows, prop_rows = [], []
    for keys, res in runs:
        claim_rows += _claim_rows(res["readings"], keys)
        prop_rows += _proportion_rows(res["proportions"], roughness_um, keys)
    return ScenarioResult(claims=pd.concat(claim_rows, ignore_index=True),
                          proportions=pd.DataFrame(prop_rows), settings=dict(settings or {}),
                          runs=list(runs))


def evaluate_scenarios(pool, hypotheses=None, observers=None, n_studies: int = 400,
                       n_per_group: int = 15, familiarise_reps: int = 1, params=None,
                       seed: int = 0, sweep=None, variability=None,
                       max_studies: int | None = None) -> ScenarioResult:
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
    max_studies : int, optional
        Add studies sequentially up to this cap (:func:`run_scenarios`); default: exactly
        ``n_studies``.
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
                           sweep=sweep, decisions=table2_plans, max_studies=max_studies)
    runs = [({"hypothesis": sc["hypothesis"], "observer": sc["observer"]}, res)
            for sc, res in zip(scenarios, merged)]
    return result_from_runs(runs, pool.roughness_um, {
        "n_studies": int(n_studies), "max_studies": int(max_studies or n_studies),
        "n_per_group": int(n_per_group), "familiarise_reps": int(familiarise_reps),
        "seed": int(seed), "roughness_um": [float(r) for r in pool.roughness_um],
        "table2_replay_models": {h: replay_models(v) for h, v
                                                    in table2_plans.items()},
        **pool.settings})


def best_scenario(result: ScenarioResult, reading: str = "descriptive",
                  key: str = "all") -> tuple[str, str]:
    """``(hypothesis, observer)`` that best matches the paper's evidence in one reading.

    The paper reports one study in which every claim held: the scenario under which a study
    shows all of them at once most often (claim ``all``) matches it best; ties (to two decimals)
    go to the higher mean probability over the single claims, then to the earlier row
    (hypotheses in :data:`stimuli.paper.REPLAY_NAMES` order; observers in
    :data:`..observers.OBSERVERS` order).  ``key="all_paper"``: the same on the paper's own
    claims alone (without the project's ``*`` criteria).
    """
    wide = result.wide(reading)
    key = key if key in wide.columns else "all"
    single = wide.drop(columns=["all", "all_paper"], errors="ignore").mean(axis=1)
    score = pd.DataFrame({"all": wide[key].round(2), "mean": single})
    order = score.sort_values(["all", "mean"], ascending=False, kind="stable")
    return tuple(order.index[0])


def tied_scenarios(result: ScenarioResult, best, reading: str = "descriptive",
                   key: str = "all") -> list:
    """Scenarios other than ``best`` tied with it on :func:`best_scenario`'s first key.

    That is the probability of showing every claim in one study, rounded to two decimals;
    among them the choice went to the higher mean probability of the single claims.
    """
    wide = result.wide(reading)
    key = key if key in wide.columns else "all"
    if key not in wide.columns:
        return []
    rounded = wide[key].round(2)
    return [k for k in wide.index if k != tuple(best) and rounded.loc[k] == rounded.loc[tuple(best)]]


#: Choices the headline depends on, each with its alternatives (label -> changes).  Keys of a
#: change: ``receptor_depth_um`` / ``sensor_tau_s`` (a pool built for it), ``noise``,
#: ``familiarise_reps``, ``lab`` (:class:`..studies.LabVariability` fields).  The first
#: setting of each choice marked "(default)" is the headline's own.
SENSITIVITY_CHOICES = {
    "receptor depth (hypothesis)": {
        "scales with skin thickness: 0.35-0.45 L below the surface (default)": {},
        f"fixed absolute depth: {ABSOLUTE_RECEPTOR_DEPTH_UM:g} µm below the surface for all": {
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
    "contact force per touch (clipped to 2.05-3 N: past the 2 N trigger)": {
        "2.2 ± 0.1 N (just past the trigger)": {"lab": {"force_N": 2.2, "force_sd_N": 0.1}},
        "2.5 N every touch": {"lab": {"force_sd_N": 0.0}},
        "2.5 ± 0.25 N (default)": {},
        "2.5 ± 0.5 N": {"lab": {"force_sd_N": 0.5}},
    },
    "pad sensor lag": {
        "none (default)": {},
        "0.1 s (pad face slewed to the 10 °C/s rate limit)": {"sensor_tau_s": 0.1},
        "0.3 s (pad face slewed to the 10 °C/s rate limit)": {"sensor_tau_s": 0.3},
    },
    "skin temperature of the replays": {
        "35.5 °C (the protocol's [simulation] skin_temperature_C; default)": {},
        "36 °C (the paper's simulations)": {"replay_skin_C": 36.0},
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


#: The keys of a sensitivity change that need a person pool of their own.
POOL_KEYS = ("receptor_depth_um", "sensor_tau_s", "replay_skin_C")
#: Of those, the keys that change only the replayed profiles (the pool's real features reused).
REAL_UNCHANGED = ("sensor_tau_s", "replay_skin_C")


def sensitivity(pool, hypothesis: str, observer: str, n_studies: int = 400, seed: int = 0,
                protocol="roughness_recognition", sweep=None, variability=None,
                extra_pools: dict | None = None, choices=None, max_studies: int | None = None,
                default_run: dict | None = None) -> pd.DataFrame:
    """The headline scenario with one choice changed at a time (:data:`SENSITIVITY_CHOICES`).

    Parameters
    ----------
    extra_pools : dict, optional
        ``(key, value) -> PersonPool`` already built for a pool-changing setting (e.g. a fitted
        receptor depth), used instead of building it.
    choices : dict, optional
        Default :data:`SENSITIVITY_CHOICES`.
    max_studies : int, optional
        Add studies to a row sequentially up to this cap (:func:`run_scenarios`).
    default_run : dict, optional
        The headline scenario's own studies (a merged result of :func:`run_scenarios`): rows
        that change nothing (``{}``) are this run, so every default row is the same numbers as
        the claims table's headline row; without it they are simulated like the others.

    Returns
    -------
    pandas.DataFrame
        One row per (choice, setting): the claims' probabilities in both readings
        (``<claim>`` descriptive, ``<claim>_inf`` inferential) with their intervals
        (``_low`` / ``_high``), ``n_studies``, the headline's status in each reading
        (``status`` / ``status_inf``, on every claim; ``paper_status`` / ``paper_status_inf`` on
        the paper's own claims), ``differs`` (claims whose interval does not overlap the
        default's) and the expected proportion correct, real and simulated, per group (mean
        over samples).  The attribute ``runs`` holds ``(keys, merged result)`` per row
        (:class:`StudyRuns`: shared, not copied, by the frames made from the table).
    """
    import dataclasses as dc
    from experiments.simulation.studies import DEFAULT_LAB, GROUPS
    base_lab = variability or DEFAULT_LAB
    extra_pools = dict(extra_pools or {})
    choices = SENSITIVITY_CHOICES if choices is None else choices
    extra_pools.update(_sensitivity_pools(pool, hypothesis, choices, extra_pools, protocol,
                                          sweep))
    scenarios, labels, notes = [], [], []
    for ci, (choice, settings) in enumerate(choices.items()):
        for si, (label, change) in enumerate(settings.items()):
            if not change and default_run is not None:
                labels.append((choice, label))
                scenarios.append(None)
                notes.append("")
                continue
            use_pool, params, lab = change.get("pool", pool), pool.params, base_lab
            for key in POOL_KEYS:
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
            notes.append(_slew_note(use_pool) if "sensor_tau_s" in change else "")
    simulated = iter(run_scenarios(pool, [sc for sc in scenarios if sc is not None], n_studies,
                                   seed=seed, sweep=sweep, max_studies=max_studies))
    merged = [default_run if sc is None else next(simulated) for sc in scenarios]
    rows = [dict(sensitivity_row(choice, label, res), note=note)
            for (choice, label), res, note in zip(labels, merged, notes)]
    table = mark_differences(pd.DataFrame(rows), choices)
    table.attrs["runs"] = StudyRuns(({"choice": c, "setting": s}, res)
                                    for (c, s), res in zip(labels, merged))
    return table


class StudyRuns(tuple):
    """A sensitivity table's runs, ``((keys, merged result), ...)`` per row, in its ``attrs``.

    pandas deep-copies ``attrs`` into every frame made from a table (a filter, a column, a
    concatenation: ``NDFrame.__finalize__``); with the rows' per-study arrays in a list that was
    ~0.1 s each, 1.8 s of ``reproduce figure9``'s report written after everything else (measured,
    ``depth_paragraph`` alone 1.6 s).  Nothing changes the runs once the table is made, so a
    copy of the table shares them, as a copy of any immutable value does.
    """
    __slots__ = ()

    def __deepcopy__(self, memo):
        return self

    def __add__(self, other):
        return StudyRuns(tuple(self) + tuple(other))


def _sensitivity_pools(pool, hypothesis, choices, have: dict, protocol, sweep) -> dict:
    """The person pools the settings need and ``have`` lacks, built first (on the sweep's
    workers when there is one): ``(key, value) -> PersonPool``."""
    wanted = {}
    for settings in choices.values():
        for change in settings.values():
            for key in POOL_KEYS:
                k = (key, change.get(key))
                if key in change and k not in have and k not in wanted:
                    # the sensor lag and the replays' skin temperature change only the replayed
                    # profiles: the same persons touching the same real samples (the real
                    # features do not depend on them), so the pool's real features are reused
                    same_people = ({"receptor_depth_um": pool.receptor_depth_um,
                                    "real_from": pool} if key in REAL_UNCHANGED else {})
                    wanted[k] = {"hypotheses": (hypothesis,), "seed": pool.settings["seed"],
                                 "params": pool.params,
                                 "dermis_fraction": pool.settings["dermis_fraction"],
                                 key: change[key], **same_people}
    if not wanted:
        return {}
    jobs = [(protocol, kw) for kw in wanted.values()]
    built = (sweep.map(build_pool_task, jobs, what="person pools") if sweep is not None
             else [build_pool_task(*job) for job in jobs])
    return dict(zip(wanted, built))


def _slew_note(pool) -> str:
    """How a sensor-lag pool's pad face was made realisable (the display's rate limit)."""
    peak = pool.settings.get("sensor_lag_peak_rate_C_per_s", 0.0)
    limit = pool.settings.get("max_rate_C_per_s", float("inf"))
    if peak > limit:
        return (f"pad face T + tau dT/dt would reach {peak:.0f} °C/s; slewed to the display's "
                f"{limit:g} °C/s")
    return f"pad face within the {limit:g} °C/s rate limit (peak {peak:.1f} °C/s)"


def sensitivity_row(choice, label, res) -> dict:
    """One row of :func:`sensitivity` from a run's merged result."""
    from analysis.claims import CLAIMS
    from experiments.simulation.figure9.precision import claim_status, scenario_status
    from experiments.simulation.studies import GROUPS
    own = {c.id for c in CLAIMS if c.own}
    row = {"choice": choice, "setting": label}
    for reading, suffix in (("descriptive", ""), ("inferential", "_inf")):
        statuses = {}
        for r in _claim_rows({reading: res["readings"][reading]}, {})[0].itertuples():
            row[r.claim + suffix] = r.probability
            row[r.claim + suffix + "_low"] = r.mc_low
            row[r.claim + suffix + "_high"] = r.mc_high
            row["n_studies"] = int(r.n_studies)
            if r.claim != "all":
                statuses[r.claim] = claim_status(r.mc_low, r.mc_high)
        row["status" + suffix] = scenario_status(statuses.values())
        row["paper_status" + suffix] = scenario_status(v for k, v in statuses.items()
                                                       if k not in own)
    p = res["proportions"].mean(axis=0)                         # (groups, modes, C)
    for gi, g in enumerate(GROUPS):
        row[f"p_real_{g}"] = float(p[gi, 0].mean())
        row[f"p_sim_{g}"] = float(p[gi, 1].mean())
    return row


def mark_differences(table: pd.DataFrame, choices) -> pd.DataFrame:
    """``differs``: the claims (``_inf``: inferential) of each row whose interval does not
    overlap the default row's (the first setting whose change is ``{}``); empty otherwise."""
    defaults = [(c, s) for c, settings in choices.items() for s, ch in settings.items() if not ch]
    table = table.copy()
    table["differs"] = ""
    if not defaults or table.empty:
        return table
    ref = table[(table.choice == defaults[0][0]) & (table.setting == defaults[0][1])].iloc[0]
    claims = [c[:-4] for c in table.columns if c.endswith("_low") and c[:-4] + "_high" in table]
    for i, row in table.iterrows():
        table.at[i, "differs"] = " ".join(
            c for c in claims if row[c + "_low"] > ref[c + "_high"] or row[c + "_high"] < ref[c + "_low"])
    return table

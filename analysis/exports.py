"""Tidy exports for R/JASP: full-precision CSVs, a JSON codebook, wide and count tables, settings.

Machine tables are written with every float at full precision (Python's shortest
round-trip ``repr``), never rounded; ``report.md`` rounds for reading.
``codebook.json`` gives, for every CSV written, every column's unit and meaning;
:func:`check_codebook` fails when a column lacks an entry (tests call it).
"""
from __future__ import annotations

import json
import os
import platform
import sys
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd

from sessionfiles.atomicfile import output_path
from sessionfiles.columns import CATEGORY, CODEBOOK

__all__ = ["write_csv", "csv_text", "wide_table", "cell_counts", "codebook", "check_codebook",
           "run_settings", "COLUMNS"]

_C = CATEGORY
_N = "count"
_F = "fraction 0-1"
_L = "log odds"
_P = "probability 0-1"
#: Unit and meaning of every column any machine table may hold (one vocabulary for all files):
#: the trials table's own columns from the one column table (:data:`sessionfiles.columns.CODEBOOK`),
#: then those analysis makes.
COLUMNS = {
    **CODEBOOK,
    # identifiers and design
    "stimulus_roughness_id": (_C, "sample presented (1-4)"),
    "familiarisation": ("bool", "row of a familiarisation (unscored) block"),
    "display_backend": (_C, "display the session ran on: the scheme of session.json's display_url "
                            "(serial, emulator, qemu-firmware, tcs2, ...; empty: not recorded)"),
    "device_id": (_C, "the display device's id as HELLO (or the TCS II's identification) gave it, "
                      "from session.json's displays; several joined by ' + ' (empty: not "
                      "recorded)"),
    "firmware_image_id": (_C, "the firmware image's id the device reported (the thermocue "
                              "firmware's build id, a TCS II's firmware version), from "
                              "session.json's displays; several joined by ' + ' (empty: not "
                              "recorded)"),
    "contact_model": (_C, "the protocol's [simulation] contact_model: press (finger presses onto "
                          "the pad) or resting (probe rests on the skin); empty: not recorded"),
    "protocol_name": (_C, "the session's protocol"),
    "protocol_hash": (_C, "hash of the session's stored protocol"),
    "condition": (_C, "display_backend/contact_model (unrecorded for a value not recorded): "
                      "trials of different conditions are never pooled (--condition)"),
    "included": ("bool", "row used in the analysis"),
    "exclusion": (_C, "why the row is not used (familiarisation, status, superseded attempt)"),
    "source": ("path", "file the row was read from"),
    "line": ("index", "line of that file"),
    "path": ("path", "session folder"),
    "n_rows": (_N, "rows read from the session"),
    "skipped": (_C, "why the session was skipped (empty if used)"),
    "reason": (_C, "missing_trials.csv: why a scheduled trial has no answer (time_out, no_contact, "
                   "fault, session_ended, other); sessions.csv: why the session is or is not "
                   "analysed"),
    "detail": (_C, "the logged detail behind the reason"),
    "attempts": (_N, "attempts logged for the trial"),
    "sessions": (_N, "session folders of the participant"),
    "scheduled": (_N, "scored trials scheduled"),
    "answered": (_N, "scheduled scored trials with an answer (an ok attempt)"),
    "analysed_trials": (_N, "answered trials the models use (included)"),
    "answered_excluded": (_N, "answered trials left out of the analysis (reason in "
                              "all_trials.csv's exclusion, e.g. a fingertip out of range)"),
    "missing": (_N, "scheduled scored trials without an answer (no ok attempt)"),
    "time_out": (_N, "missing trials: time-out"),
    "no_contact": (_N, "missing trials: no touch within the trial time-out"),
    "fault": (_N, "missing trials: display or software fault on the last attempt"),
    "session_ended": (_N, "missing trials: the session stopped before or during the trial"),
    "other": (_N, "missing trials: another reason (see missing_trials.csv)"),
    "schedule_source": (_C, "where the schedule came from: session.json or the logged trials"),
    "complete": ("bool", "the session's log says it finished (session_finished)"),
    "n_done": (_N, "trials the session completed"),
    "n_planned": (_N, "trials the session's schedule planned"),
    "created_at": ("ISO 8601 UTC", "time the session was created"),
    "analysed": ("bool", "the session's rows are analysed under the --sessions policy"),
    # counts and proportions
    "n_participants": (_N, "participants contributing"),
    "n_trials": (_N, "trials"),
    "n_correct": (_N, "correct answers"),
    "k": (_N, "correct answers of the participant in the cell"),
    "n": (_N, "answered trials of the participant in the cell"),
    "proportion_correct": (_F, "fraction of trials answered correctly"),
    "proportion_of_stimulus": (_F, "share of the stimulus's trials given this response"),
    "wilson_low": (_F, "Wilson score interval, lower end (trials independent)"),
    "wilson_high": (_F, "Wilson score interval, upper end"),
    "boot_low": (_F, "Wilson interval at the effective n from a participant-cluster bootstrap's "
                     "design effect, lower end (plain Wilson with one participant)"),
    "boot_high": (_F, "the same interval, upper end"),
    "boot_se": (_F, "bootstrap standard error of proportion_correct"),
    "design_effect": ("ratio", "bootstrap variance x m/(m-1) over binomial variance, floored at 1"),
    "median_rt_s": ("s", "median response time"),
    "q25_rt_s": ("s", "first quartile of response time"),
    "q75_rt_s": ("s", "third quartile of response time"),
    "mean_force_N": ("N", "mean contact force the display measured (contact_force_N)"),
    "sd_force_N": ("N", "standard deviation of contact_force_N across trials"),
    "min_force_N": ("N", "smallest contact_force_N"),
    "max_force_N": ("N", "largest contact_force_N"),
    # models
    "term": (_C, "model term (patsy name; treatment coding: group A, real, 1# are the reference)"),
    "log_odds": (_L, "estimate on the log-odds scale (participant_sd, sd_*: SDs of the random "
                     "effects, log odds; icc_latent: fraction 0-1; corr_*: correlation; "
                     "lrt_slope: likelihood-ratio statistic)"),
    "se": (_L, "standard error of the estimate"),
    "p_value": (_P, "two-sided p-value, unadjusted"),
    "p_holm": (_P, "Holm-adjusted p-value within the table's family of tests"),
    "ci_low": (_L, "confidence interval, lower end (same scale as the estimate)"),
    "ci_high": (_L, "confidence interval, upper end"),
    "interval": (_C, "how the interval was computed and its reference distribution (Wald, "
                     "t(df) or normal; profile likelihood with its cut-off)"),
    "posterior_mean": (_L, "variational posterior mean (demoted mean-field VB)"),
    "posterior_sd": (_L, "variational posterior SD (too small: mean-field)"),
    "cri_low": (_L, "variational credible interval, lower end"),
    "cri_high": (_L, "variational credible interval, upper end"),
    "model": (_C, "model the row comes from"),
    # model_decisions.csv: the scene planner's decisions for the simulated profiles
    "effect": (_C, "physical effect of the thermal model (stimuli.scene)"),
    "decision": (_C, "kept or neglected by the scene planner"),
    "n_profiles": (_N, "distinct target profiles with this decision"),
    "max_bound_K": ("K", "largest error neglecting the effect causes over those profiles"),
    "tolerance_K": ("K", "smallest tolerance the planner was asked for"),
    "note": (_C, "model_decisions.csv: the effect, or why it was kept; tests.csv: a fallback, "
                 "a convergence problem or the choice of model that changes the row"),
    "log_odds_ratio_A_vs_B": (_L, "log odds of correct, group A minus group B"),
    "odds_ratio_A_vs_B": ("ratio", "exp(log_odds_ratio_A_vs_B)"),
    "p_correct_A": (_P, "model probability of a correct answer, group A (averaged row: mean of "
                        "the samples' probabilities)"),
    "p_correct_B": (_P, "same for group B"),
    "difference_A_minus_B": (_F, "p_correct_A - p_correct_B (difference of mean proportions)"),
    "difference_low": (_F, "delta-method interval of the difference, lower end"),
    "difference_high": (_F, "delta-method interval of the difference, upper end"),
    "basis": (_C, "where the row comes from (fitted model, per-sample GEE, not estimable)"),
    "compares": (_C, "in words: what the row compares"),
    "test": (_C, "name of the test with its reference distribution (Wald t(df), Wald z (normal), "
                 "Wald F(q, m - q))"),
    "role": (_C, "primary, omnibus, per-sample, interaction"),
    "hypothesis": (_C, "null hypothesis in words"),
    "statistic": ("see test", "test statistic: estimate / se referred to the distribution in "
                              "test (t or normal), or F for the omnibus test"),
    "df": (_N, "degrees of freedom of the reference distribution (t: its df; F: the numerator "
               "df; empty: normal)"),
    # fidelity.csv: real vs simulated
    "scale": (_C, "population-averaged (GEE) or typical participant (mixed model, u = 0)"),
    "difference_se": (_F, "delta-method standard error of difference"),
    "margin": (_F, "equivalence margin on the proportion scale (protocol's "
                   "equivalence_margin_pp / 100)"),
    "tost_p_value": (_P, "two one-sided tests of |difference| >= margin: the larger one-sided "
                         "p-value (equivalence shown when < 0.05)"),
    "tost_ci_low": (_F, "90 % interval of difference (the TOST's), lower end"),
    "tost_ci_high": (_F, "90 % interval of difference, upper end"),
    "equivalent": ("0/1", "1 if the TOST shows equivalence within the margin"),
    "estimate": ("see compares", "estimate of the compared quantity (log odds unless stated)"),
    "difference": (_F, "the compared quantity as a difference of proportions"),
    "difference_ci_low": (_F, "its interval, lower end"),
    "difference_ci_high": (_F, "its interval, upper end"),
    "family": (_C, "family of tests within which p_holm adjusts"),
    "mean_participant_proportion": (_F, "mean over participants of their proportion correct"),
    "t_low": (_F, "t interval of mean_participant_proportion, lower end"),
    "t_high": (_F, "t interval of mean_participant_proportion, upper end"),
    "t": ("ratio", "(mean - 0.25) / standard error"),
    # psychophysics
    "it_bits": ("bits", "information transfer, plug-in estimate"),
    "it_bits_corrected": ("bits", "information transfer, Miller-Madow bias-corrected"),
    "stimulus_entropy_bits": ("bits", "entropy of the stimulus distribution"),
    "relative_it": (_F, "it_bits_corrected / stimulus_entropy_bits"),
    "kappa": ("ratio", "Cohen's kappa of stimulus vs response"),
    "mean_hu": (_F, "mean of Wagner's unbiased hit rates over the samples"),
    "measure": (_C, "per-participant measure summarised (it_bits_corrected, kappa, mean_hu)"),
    "hit_rate": (_F, "proportion of the sample's trials named correctly"),
    "hu": (_F, "Wagner's unbiased hit rate"),
    "hu_chance": (_F, "chance value of hu for these marginals"),
    "spearman_pooled": ("ratio", "Spearman rank correlation of stimulus and response, all trials"),
    "mean_participant_spearman": ("ratio", "mean (Fisher z) of the participants' own Spearman rho"),
    "t_p_value": (_P, "one-sample t-test of the participants' Fisher z against 0, t(t_df)"),
    "t_df": (_N, "degrees of freedom of that t-test (participants - 1)"),
    "po_slope": (_L, "proportional-odds log odds of a higher answer per sample step"),
    "po_se": (_L, "its participant-cluster-robust standard error"),
    "po_ci_low": (_L, "interval, lower end"),
    "po_ci_high": (_L, "interval, upper end"),
    "meaning": (_C, "what the coefficient means"),
    # power
    "n_per_group": (_N, "participants per group (group A when groups differ)"),
    "effect_pp": ("percentage points", "stated A - B difference of population-averaged mean "
                                       "proportions correct in the tested mode (the smallest "
                                       "effect of interest), not an observed one"),
    "n_group_A": (_N, "participants in group A"),
    "n_group_B": (_N, "participants in group B"),
    "simulations": (_N, "simulated cohorts"),
    "power": (_F, "share of cohorts rejecting no group difference"),
    "power_low": (_F, "Wilson interval of power (Monte Carlo error), lower end"),
    "power_high": (_F, "Wilson interval of power, upper end"),
    "power_right_sign": (_F, "share rejecting with group A higher"),
    "mean_difference_A_minus_B": (_F, "mean observed A - B proportion difference"),
    "expected_difference_A_minus_B": (_F, "A - B difference of mean proportions the model implies"),
    "participant_sd": (_L, "SD of participant random intercepts"),
    "sd_basis": (_C, "where the participant SD of these rows comes from: the analysis's point "
                     "estimate, an end of its 95 % profile interval, or stated"),
    "alpha": (_P, "two-sided significance level"),
    "missing_rate": (_F, "share of scheduled trials dropped at random"),
    "fallbacks": (_F, "share of cohorts fitted with a fallback formula"),
    "cells_scale": (_C, "conditional: cells are a typical participant's; marginal: population "
                        "averages converted to a typical participant's"),
    "p_correct": (_P, "probability of a correct answer for a typical participant (u = 0)"),
}


def write_csv(df: pd.DataFrame, path: Path) -> Path:
    """Write a machine table at full precision (no rounding), whole or not at all.

    The bytes of ``df.to_csv(path, index=False)``; a table of plain numbers and strings that
    need no quotes is formatted column by column (:func:`csv_text`, ~10x faster on the
    reproduction's 17,600-row per-study table), anything else by pandas itself.
    """
    columns = _csv_columns(df)
    with output_path(path) as tmp:
        if columns is None:
            df.to_csv(tmp, index=False)
        else:
            with open(tmp, "wb") as fh:
                for chunk in _csv_chunks(list(df.columns), columns):
                    fh.write(chunk.encode("utf-8"))
    return path


#: A character that makes the csv module quote a field (pandas' QUOTE_MINIMAL): such tables are
#: left to pandas.
_NEEDS_QUOTES = frozenset(',"\r\n')


def csv_text(df: pd.DataFrame) -> str | None:
    """``df.to_csv(index=False)``'s text, built one column at a time; None where that is not
    certain (then call pandas).

    Handled: at least two columns named by strings, each column float64 (numpy's shortest
    round-trip text, what pandas writes; NaN blank), a numpy integer or bool dtype, or strings
    (object or pandas' string dtype; missing ones blank; a field with ``,`` or ``"`` quoted as
    the csv module's QUOTE_MINIMAL quotes it, ``"`` doubled) with neither ``\\r`` nor ``\\n``
    in any field, and none of ``,"\\r\\n`` in a name. Lines end with ``\\n``, as pandas'
    default on POSIX.
    """
    columns = _csv_columns(df)
    return None if columns is None else "".join(_csv_chunks(list(df.columns), columns))


def _csv_columns(df: pd.DataFrame) -> list[list[str]] | None:
    """Each column's fields as text (:func:`csv_text`'s), or None."""
    if os.linesep != "\n" or df.shape[1] < 2:
        return None
    names = list(df.columns)
    if not all(isinstance(n, str) and _NEEDS_QUOTES.isdisjoint(n) for n in names):
        return None
    columns = []
    for i in range(df.shape[1]):
        col = df.iloc[:, i]
        dtype = col.dtype
        if dtype == np.float64:
            values = col.to_numpy()
            zero = values == 0
            if zero.any() and np.signbit(values[zero]).any():     # -0.0 and 0.0 unique as one
                text = np.array([repr(v) for v in values.tolist()], dtype=object)
            else:
                text = _each_distinct(values, repr)
            missing = np.isnan(values)
            if missing.any():
                text[missing] = ""
        elif isinstance(dtype, np.dtype) and dtype.kind in "iu":
            text = _each_distinct(col.to_numpy(), str)
        elif dtype == bool:
            text = np.where(col.to_numpy(), "True", "False")
        elif dtype == object or isinstance(dtype, pd.StringDtype):
            values = col.to_numpy(dtype=object)
            missing = col.isna().to_numpy()
            text = np.where(missing, "", values)
            quoted = {}                    # the csv module's QUOTE_MINIMAL, per distinct field
            for v in text:
                if type(v) is not str:
                    return None
                if not _NEEDS_QUOTES.isdisjoint(v) and v not in quoted:
                    if "\r" in v or "\n" in v:      # quoted or not by the line ending: pandas
                        return None
                    quoted[v] = '"' + v.replace('"', '""') + '"'
            if quoted:
                text = np.array([quoted.get(v, v) for v in text.tolist()], dtype=object)
        else:
            return None
        columns.append(text.tolist())
    return columns


def _csv_chunks(names: list, columns: list, rows: int = 2048):
    """The CSV text of ``columns`` (:func:`_csv_columns`) in pieces of ``rows`` lines, the
    header first (a few MB at a time, not the whole 11 MB of a per-study table)."""
    yield ",".join(names) + "\n"
    n = len(columns[0]) if columns else 0
    for start in range(0, n, rows):
        part = [c[start:start + rows] for c in columns]
        yield "".join([",".join(row) + "\n" for row in zip(*part)])


def _each_distinct(values: np.ndarray, text) -> np.ndarray:
    """``text`` of each value (Python's ``repr`` of a float is pandas' CSV text, numpy's
    shortest round trip), computed once per distinct value: a per-study table repeats a few
    hundred proportions over thousands of rows."""
    distinct, where = np.unique(values, return_inverse=True)
    return np.array([text(v) for v in distinct.tolist()], dtype=object)[where.reshape(-1)]


def wide_table(trials: pd.DataFrame) -> pd.DataFrame:
    """One row per participant, one column per condition (proportion correct).

    Returns
    -------
    pandas.DataFrame
        ``participant, group, skin_thickness_um`` then ``p_<mode>_<r>`` for each
        mode and sample and ``p_<mode>_all`` (fractions 0-1; blank when the
        participant has no trial in that condition).
    """
    base = trials.groupby("participant").agg(group=("group", "first"),
                                             skin_thickness_um=("skin_thickness_um", "first"))
    cell = trials.pivot_table(index="participant", columns=["mode", "roughness_id"],
                              values="correct", aggfunc="mean")
    cell.columns = [f"p_{m}_{r}" for m, r in cell.columns]
    mode = trials.pivot_table(index="participant", columns="mode", values="correct",
                              aggfunc="mean")
    mode.columns = [f"p_{m}_all" for m in mode.columns]
    return base.join(cell).join(mode).reset_index()


def cell_counts(trials: pd.DataFrame) -> pd.DataFrame:
    """Per participant × cell: correct answers ``k`` of ``n`` (for binomial GLMMs in R/JASP)."""
    g = trials.groupby(["participant", "group", "mode", "roughness_id"])["correct"]
    return pd.DataFrame({"k": g.sum().astype(int), "n": g.size()}).reset_index()


def codebook(files: dict) -> dict:
    """The codebook of the CSVs in ``files`` (name -> Path): every column's unit and meaning.

    Columns named ``p_<mode>_<r>`` (the wide table) and ``proportion_correct_r<r>``
    (participants.csv) are described by pattern.
    """
    book = {}
    for path in files.values():
        path = Path(path)
        if path.suffix != ".csv":
            continue
        try:
            columns = pd.read_csv(path, nrows=0).columns
        except pd.errors.EmptyDataError:          # a table with no columns (model not fitted)
            columns = []
        entry = {}
        for c in columns:
            if c in COLUMNS:
                unit, meaning = COLUMNS[c]
            elif c.startswith("proportion_correct_r") and c[20:].isdigit():
                unit, meaning = _F, f"participant's proportion correct on sample {c[20:]}#"
            elif c.startswith("p_") and c.count("_") >= 2:
                _, mode, which = c.split("_", 2)
                unit, meaning = _F, (f"participant's proportion correct, {mode} samples, "
                                     + ("all samples" if which == "all" else f"sample {which}#"))
            else:
                unit, meaning = None, None
            entry[c] = {"unit": unit, "meaning": meaning}
        book[path.name] = entry
    return book


def check_codebook(book: dict) -> list[str]:
    """Columns of the codebook without a unit or meaning (``file: column``)."""
    return [f"{f}: {c}" for f, cols in book.items() for c, v in cols.items()
            if v["unit"] is None or v["meaning"] is None]


def run_settings(**settings) -> dict:
    """The run's settings plus Python, platform and package versions (JSON-ready)."""
    versions = {}
    for name in ("thermocue", "numpy", "scipy", "pandas", "statsmodels", "patsy", "matplotlib"):
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    out = {k: (str(v) if isinstance(v, Path) else v) for k, v in settings.items()}
    out.update(python=sys.version.split()[0], platform=platform.platform(), versions=versions)
    return json.loads(json.dumps(out, default=lambda v: v.item() if isinstance(v, np.generic)
                                 else str(v)))

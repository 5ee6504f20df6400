"""Real vs simulated samples: does the display's replay feel like the real sample?

The display's own question is an equivalence question: are simulated samples recognised *as
well as* real ones, within a margin the protocol states? This module answers it from a fitted
model of ``correct ~ group * mode * C(roughness_id)``:

- the **averaged mode contrast** (real - simulated), per group and overall (the two groups
  weighted equally), averaged over the samples: on the log-odds scale (the mean log odds of the
  real cells minus that of the simulated ones) and as a difference of mean proportions (delta
  method). From the GEE it is population-averaged, from a mixed logit that of a typical
  participant (random effects 0);
- the **equivalence test**: two one-sided tests (TOST [1]_) of the overall difference of mean
  proportions against the margin +-delta: H0 ``|real - simulated| >= delta``; equivalence is
  shown when both one-sided p-values are below alpha (equivalently, the ``1 - 2 alpha`` interval
  lies inside +-delta);
- the **per-sample mode contrasts** (group x sample, 8 rows), Holm-adjusted over the 8 (over
  those tested: the rows of a group of one participant have no p-value).

Reference distributions (:func:`contrast_df`): a GEE row of one group is a within-participant
contrast resting on that group's ``m_g`` participants, so t(m_g - 1) (as a paired t-test); a
row of both groups the Welch-Satterthwaite df of its two groups' parts. From the random-slope
mixed model the SE of each contrast is the CR2 participant sandwich
(:func:`analysis.models.contrast_se`) and its df the Bell-McCaffrey df
(:func:`analysis.small_sample.row_df`); the intercept-only model's rows use t(m - 2) (their
model-based SE rests on every participant's likelihood). A group of one participant has no
reference: its rows and the both-groups row get no p-value, interval or equivalence test
(``test`` says why).

References
----------
.. [1] D. J. Schuirmann, "A comparison of the two one-sided tests procedure and the power
   approach for assessing the equivalence of average bioavailability", J. Pharmacokinet.
   Biopharm. 15 (1987) 657-680.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import special, stats

from sessionfiles.session_reader import read_text_file

from .errors import LogError
from .inference import holm
from .small_sample import row_df
from .wording import df_text, p_text, signed
from .design import design_rows
from .models import (ModelFit, contrast_se, design_gap, model_data, reference_p,
                     reference_quantile)

__all__ = ["DEFAULT_EQUIVALENCE_MARGIN_PP", "mode_contrasts", "tost", "equivalence_margin",
           "FIDELITY_COLUMNS"]

#: Default equivalence margin, percentage points of proportion correct (real - simulated,
#: averaged over the samples); the protocol's ``[analysis] equivalence_margin_pp`` overrides it.
DEFAULT_EQUIVALENCE_MARGIN_PP = 10.0
_MARGIN_RANGE = (0.0, 50.0)

#: Columns of :func:`mode_contrasts`.
FIDELITY_COLUMNS = ["role", "model", "scale", "group", "roughness_id", "compares", "estimate",
                    "se", "ci_low", "ci_high", "interval", "test", "df", "statistic", "p_value",
                    "p_holm", "difference", "difference_se", "difference_ci_low",
                    "difference_ci_high", "margin", "tost_p_value", "tost_ci_low",
                    "tost_ci_high", "equivalent", "basis", "note"]


def tost(estimate: float, se: float, margin: float, df: float | None,
         alpha: float = 0.05) -> dict:
    """Two one-sided tests of ``|true value| >= margin`` from an estimate and its SE.

    Parameters
    ----------
    estimate, se : float
        The estimate and its standard error (same scale as ``margin``).
    margin : float
        The equivalence margin, > 0.
    df : float or None
        Degrees of freedom of the t reference (None: normal).
    alpha : float
        Size of each one-sided test.

    Returns
    -------
    dict
        ``p_lower`` (H0: value <= -margin), ``p_upper`` (H0: value >= margin), ``p_value``
        (the larger; equivalence when < alpha), ``ci_low, ci_high`` (the ``1 - 2 alpha``
        interval), ``equivalent`` (bool).

    Examples
    --------
    >>> r = tost(0.01, 0.03, 0.10, None)
    >>> round(r["p_value"], 4), r["equivalent"]
    (0.0013, True)
    """
    if not (np.isfinite(estimate) and np.isfinite(se) and se > 0):
        return {"p_lower": np.nan, "p_upper": np.nan, "p_value": np.nan, "ci_low": np.nan,
                "ci_high": np.nan, "equivalent": False}
    dist = stats.t(df) if df else stats.norm()
    p_lower = float(dist.sf((estimate + margin) / se))
    p_upper = float(dist.cdf((estimate - margin) / se))
    q = float(dist.ppf(1 - alpha))
    p = max(p_lower, p_upper)
    return {"p_lower": p_lower, "p_upper": p_upper, "p_value": p,
            "ci_low": estimate - q * se, "ci_high": estimate + q * se,
            "equivalent": bool(p < alpha)}


def equivalence_margin(session_folders, override_pp: float | None = None) -> tuple[float, str]:
    """The equivalence margin (percentage points) and where it came from.

    The protocol stored in each analysed session's ``session.json`` may set
    ``[analysis] equivalence_margin_pp``; sessions must agree. ``override_pp`` (the command
    line) wins; without either, :data:`DEFAULT_EQUIVALENCE_MARGIN_PP`.

    Raises
    ------
    LogError
        A stored margin that is not a number in (0, 50), or sessions that disagree (the message
        names the file and the field).
    """
    lo, hi = _MARGIN_RANGE
    if override_pp is not None:
        if not (isinstance(override_pp, (int, float)) and lo < override_pp < hi):
            raise LogError(f"--equivalence-margin-pp: expected a number of percentage points "
                           f"in ({lo:g}, {hi:g}), got {override_pp!r}")
        return float(override_pp), "command line (--equivalence-margin-pp)"
    found: dict[float, str] = {}
    for folder in session_folders:
        path = Path(folder) / "session.json"
        try:
            meta = json.loads(read_text_file(path))     # the session reader's rules
        except (OSError, ValueError):
            continue                    # the loader reports unreadable session files
        protocol = meta.get("protocol") if isinstance(meta, dict) else None
        section = protocol.get("analysis") if isinstance(protocol, dict) else None
        if not isinstance(section, dict) or "equivalence_margin_pp" not in section:
            continue
        value = section["equivalence_margin_pp"]
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not lo < value < hi:
            raise LogError(f"{path}: protocol.analysis.equivalence_margin_pp: expected a number "
                           f"of percentage points in ({lo:g}, {hi:g}), got {value!r}")
        found.setdefault(float(value), str(path))
    if len(found) > 1:
        (a, pa), (b, pb) = list(found.items())[:2]
        raise LogError(f"{pb}: protocol.analysis.equivalence_margin_pp: expected the same margin "
                       f"as {pa} ({a:g}), got {b:g}")
    if found:
        (value, path), = found.items()
        return value, "the protocol ([analysis] equivalence_margin_pp)"
    return DEFAULT_EQUIVALENCE_MARGIN_PP, "default (the protocol sets none)"


def contrast_df(fit: ModelFit, data: pd.DataFrame, group: str,
                lvec=None) -> float | None:
    """Degrees of freedom of a real - simulated contrast's t reference.

    The mode effect is within participants, and in the fitted ``group * mode * sample`` model a
    group's mode contrast rests on that group's participants alone (its sandwich sums only their
    scores): a one-sample problem with ``m_g`` clusters, so ``m_g - 1`` (as a paired t-test of
    the group's participants). The contrast over both groups averages two such independent
    means: ``m - 2`` (two groups, one mean each), as every other Wald row. A fallback formula
    without a group x mode term has one mode effect for both groups, estimated from all
    participants: ``m - 2`` for every row then. ``None`` (normal) when the fit has no ``df``.
    NaN (no test, no interval: :func:`_lone_group`) when a group's contrast rests on a single
    participant, for that group's rows and the both-groups row that averages it in.

    With ``lvec`` (the row's contrast) and a fit whose variance splits by group (the GEE's
    sandwich, the random-slope model's participant sandwich), the row's df is
    :func:`analysis.small_sample.row_df`'s: Welch-Satterthwaite for the GEE (``m_g - 1`` on a
    group row), Bell-McCaffrey for the random-slope model's CR2 sandwich.
    A mixed model without a sandwich (intercept only) refers every row to ``m - 2``: its SE
    rests on the likelihood of all participants, and t(m_g - 1) made its group rows wider
    than their coverage needs.
    """
    if _lone_group(fit, data, group) is not None:
        return np.nan
    if not fit.df:
        return None
    if lvec is not None and _group_by_mode(fit) and fit.cov_by_group:
        return row_df(fit, lvec)      # Welch-Satterthwaite of the variance the SE uses
    if group == "both" or not _group_by_mode(fit) or fit.kind != "gee":
        return fit.df
    m_g = data.loc[data["group"] == group, "participant"].nunique()
    return float(m_g - 1)


def _group_by_mode(fit: ModelFit) -> bool:
    names = [t.name() for t in fit.design_info.terms]
    return any("group" in n and "mode" in n for n in names)


def _lone_group(fit: ModelFit, data: pd.DataFrame, group: str) -> str | None:
    """The group (``group`` itself, or either for "both") whose mode contrast rests on one
    participant, or None. With one participant there is no between-participant variation to
    refer the contrast to (a participant-cluster sandwich of one cluster is its score, which
    sums to 0 at the estimate; a t reference would have 0 df)."""
    if not _group_by_mode(fit):
        return None                   # one mode effect from all participants
    groups = sorted(data["group"].unique()) if group == "both" else [group]
    for g in groups:
        if data.loc[data["group"] == g, "participant"].nunique() < 2:
            return g
    return None


def _contrast(xr, xs, fit: ModelFit, z: float, df: float | None) -> dict:
    beta = fit.params
    lvec = xr.mean(axis=0) - xs.mean(axis=0)
    est, se = float(lvec @ beta), contrast_se(fit, lvec)
    qr, qs = special.expit(xr @ beta), special.expit(xs @ beta)
    diff = float(qr.mean() - qs.mean())
    grad = (qr * (1 - qr)) @ xr / len(xr) - (qs * (1 - qs)) @ xs / len(xs)
    dse = contrast_se(fit, grad)
    p = float(reference_p(est / se, df)) if se > 0 else np.nan
    return {"estimate": est, "se": se, "ci_low": est - z * se, "ci_high": est + z * se,
            "statistic": est / se if se > 0 else np.nan, "p_value": p, "difference": diff,
            "difference_se": dse, "difference_ci_low": diff - z * dse,
            "difference_ci_high": diff + z * dse}


def _test_name(df: float | None, lone: str | None = None) -> str:
    if lone is not None:
        return (f"not tested: group {lone} has 1 participant (no between-participant "
                f"reference for its mode contrast)")
    return f"Wald t({df_text(df)})" if df else "Wald z (normal)"


def _interval_name(fit: ModelFit, df: float | None) -> str:
    if df is not None and np.isnan(df):
        return "none (see test)"
    ref = f"t({df_text(df)})" if df else "normal"
    if fit.cov_robust is not None:
        return f"Wald, {ref}; SE the CR2 participant sandwich, Bell-McCaffrey df"
    return f"Wald, {ref}"


def mode_contrasts(fit: ModelFit, trials: pd.DataFrame, *, margin_pp: float,
                   level: float = 0.95, alpha: float = 0.05) -> pd.DataFrame:
    """Real - simulated contrasts from ``fit``: averaged per group and overall (with TOST), and
    per group x sample (Holm over those).

    Parameters
    ----------
    fit : ModelFit
        A GEE or mixed logit with ``group`` and ``mode`` terms.
    trials : pandas.DataFrame
        Analysable trials (the levels present).
    margin_pp : float
        Equivalence margin in percentage points of proportion correct.
    level : float
        Level of the two-sided intervals.
    alpha : float
        Size of each one-sided test of the TOST.

    Returns
    -------
    pandas.DataFrame
        :data:`FIDELITY_COLUMNS`: ``role`` "averaged" (``group`` A, B or "both") or
        "per-sample"; ``estimate`` the real - simulated log odds ratio; ``difference`` the
        difference of mean proportions (0-1); ``margin`` and ``tost_*`` on the proportion
        scale (averaged rows); ``p_holm`` over the per-sample rows. Empty without both modes.
    """
    data = model_data(trials)
    if fit.formula is None or "mode" not in fit.formula or set(data["mode"]) != {"real",
                                                                                  "simulated"}:
        return pd.DataFrame(columns=FIDELITY_COLUMNS)
    samples = sorted(data["roughness_id"].unique())
    groups = sorted(data["group"].unique())
    design_rows(fit, groups, ["real", "simulated"], samples)    # every row below, at once
    scale = ("population-averaged" if fit.kind == "gee" else "typical participant (u = 0)")
    margin = margin_pp / 100.0
    basis = f"model: {fit.formula}" + {"glmm": " + (1 | participant)",
                                       "glmm-slope": " + (1 + mode | participant)"}.get(fit.kind, "")
    note = "; ".join(fit.notes)
    rows = []
    for group in groups + (["both"] if len(groups) > 1 else []):
        which = groups if group == "both" else [group]
        xr = design_rows(fit, which, ["real"], samples)
        xs = design_rows(fit, which, ["simulated"], samples)
        df = contrast_df(fit, data, group, xr.mean(axis=0) - xs.mean(axis=0))
        c = _contrast(xr, xs, fit, reference_quantile(level, df), df)
        gap = design_gap(data, groups=which, modes=("real", "simulated"))
        if gap:                    # that group's real or simulated cells are not identified
            c = {k: np.nan for k in c}
        t = tost(c["difference"], c["difference_se"], margin, df, alpha)
        who = "groups A and B weighted equally" if group == "both" else f"group {group}"
        rows.append({"role": "averaged", "model": fit.kind, "scale": scale, "group": group,
                     "roughness_id": 0,
                     "compares": f"real - simulated, {who}, mean over the samples: log odds "
                                 f"ratio; difference of mean {scale} proportions correct",
                     **c, "interval": _interval_name(fit, df),
                     "test": f"not tested: {gap}" if gap else
                             _test_name(df, _lone_group(fit, data, group)),
                     "df": df, "p_holm": np.nan,
                     "margin": margin, "tost_p_value": t["p_value"],
                     "tost_ci_low": t["ci_low"], "tost_ci_high": t["ci_high"],
                     "equivalent": t["equivalent"], "basis": basis, "note": note})
    per = []
    for group in groups:
        gap = design_gap(data, groups=[group], modes=("real", "simulated"))
        for r in samples:
            xr = design_rows(fit, [group], ["real"], [r])
            xs = design_rows(fit, [group], ["simulated"], [r])
            df = contrast_df(fit, data, group, xr.mean(axis=0) - xs.mean(axis=0))
            c = _contrast(xr, xs, fit, reference_quantile(level, df), df)
            if gap:
                c = {k: np.nan for k in c}
            per.append({"role": "per-sample", "model": fit.kind, "scale": scale, "group": group,
                        "roughness_id": int(r),
                        "compares": f"real - simulated, group {group}, sample {r}#: log odds "
                                    f"ratio; difference of {scale} proportions correct",
                        **c, "interval": _interval_name(fit, df),
                        "test": f"not tested: {gap}" if gap else
                                _test_name(df, _lone_group(fit, data, group)),
                        "df": df, "margin": np.nan,
                        "tost_p_value": np.nan, "tost_ci_low": np.nan, "tost_ci_high": np.nan,
                        "equivalent": False, "basis": basis, "note": note})
    adjusted = holm([row["p_value"] for row in per])
    for row, a in zip(per, adjusted):
        row["p_holm"] = a
    return pd.DataFrame(rows + per, columns=FIDELITY_COLUMNS)


def fidelity_paragraph(table: pd.DataFrame, margin_pp: float, source: str,
                       alpha: float = 0.05) -> str:
    """The report's lead sentence on display fidelity (from the GEE's overall averaged row)."""
    sel = table[(table["model"] == "gee") & (table["role"] == "averaged")
                & (table["group"] == "both")]
    if sel.empty:
        return ("Real vs simulated: not estimable (both modes and a model with a mode term are "
                "needed).")
    r = sel.iloc[0]
    pp = lambda v: signed(100 * v)      # noqa: E731 - percentage points, never "-0.0"
    if r["test"].startswith("not tested"):
        estimate = (f"real minus simulated {pp(r['difference'])} percentage points of "
                    f"proportion correct; " if np.isfinite(r["difference"]) else "")
        return (f"Real vs simulated (GEE, population-averaged, both groups weighted equally, "
                f"mean over the samples): {estimate}{r['test']}: no interval and no "
                f"equivalence test.")
    verdict = ("shown: simulated samples are recognised as well as real ones within the margin"
               if r["equivalent"] else
               "not shown: the data cannot exclude a difference as large as the margin")
    per = table[(table["model"] == "gee") & (table["role"] == "per-sample")]
    named = per[per["p_holm"] < alpha]
    lines = [
        f"Real vs simulated (the display's question; GEE, population-averaged, both groups "
        f"weighted equally, mean over the samples): real minus simulated "
        f"{pp(r['difference'])} percentage points of proportion correct "
        f"(95 % CI {pp(r['difference_ci_low'])} to {pp(r['difference_ci_high'])}; log odds "
        f"ratio {signed(r['estimate'], 2)}, {r['test']} {p_text(r['p_value'])}). Equivalence "
        f"within +-{margin_pp:g} points ({source}; two one-sided {r['test']} tests at "
        f"{alpha:g}, {100 * (1 - 2 * alpha):.0f} % CI {pp(r['tost_ci_low'])} to "
        f"{pp(r['tost_ci_high'])}): {p_text(r['tost_p_value'])}, equivalence {verdict}."]
    for g in ("A", "B"):
        s = table[(table["model"] == "gee") & (table["role"] == "averaged") & (table["group"] == g)]
        if not s.empty:
            s = s.iloc[0]
            if s["test"].startswith("not tested"):
                lines.append(f"Group {g}: " + (f"{pp(s['difference'])} points; "
                             if np.isfinite(s["difference"]) else "") + f"{s['test']}.")
                continue
            lines.append(f"Group {g}: {pp(s['difference'])} points "
                         f"({pp(s['difference_ci_low'])} to {pp(s['difference_ci_high'])}), "
                         f"TOST {p_text(s['tost_p_value'])}.")
    if not per.empty:
        lines.append(
            "Per sample (8 real - simulated contrasts, Holm-adjusted): "
            + ("no sample's difference is significant at 0.05 after adjustment (which does "
               "not show that they are equal)" if named.empty else
               ", ".join(f"group {x.group} {x.roughness_id}# ({pp(x.difference)} points, "
                         f"adjusted {p_text(x.p_holm)})" for x in named.itertuples()))
            + f" (smallest adjusted {p_text(per['p_holm'].min())}).")
    return " ".join(lines)

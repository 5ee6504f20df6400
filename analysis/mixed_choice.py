"""Which mixed logit answers the questions about mode (interaction, real vs simulated).

The mode effect is within participants. When it varies between participants (a random mode
slope), the intercept-only mixed model's SE of any mode contrast ignores that variation: over
200 null datasets with a random slope (SD 0.8) its interaction test rejected 12.5 % and its
interval covered 0.82-0.88 (``benchmarks/bench_recovery.py``). Choosing the slope model only when
its likelihood-ratio test rejects would inherit that under-coverage in every dataset where the
test misses the slope (about half at 30 participants), so the rule is:

- mode contrasts and the interaction come from the random-slope model
  ``(1 + mode | participant)`` whenever it was fitted with the same fixed effects as the
  intercept-only model (its fixed-effect intervals covered 0.957 without a slope and 0.963
  with one), each contrast's SE the CR2 participant sandwich with its Bell-McCaffrey df
  (:func:`analysis.models.contrast_se`: the slope SD's ML estimate is biased low, and the
  model-based intervals of real - simulated covered 0.92);
- otherwise (the slope model failed or fell back to a simpler formula) from the intercept-only
  model, with the reason beside the row;
- the participant SDs the summary quotes come from the slope model when its LR test rejects
  (p < 0.05), else from the intercept-only model.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .models import ModelFit

__all__ = ["MixedChoice", "choose_mixed"]


@dataclass(frozen=True)
class MixedChoice:
    """The mixed model used for mode contrasts and for the participant SDs, and why.

    Attributes
    ----------
    contrasts : ModelFit or None
        The model of the GLMM interaction and mode-contrast rows.
    spread : ModelFit or None
        The model whose SDs the summary quotes.
    lrt_p : float
        p-value of the LR test of the random slope (NaN when not computed).
    reason : str
        Why these models, in words (printed beside the rows).
    """

    contrasts: ModelFit | None
    spread: ModelFit | None
    lrt_p: float
    reason: str


def _lrt_p(slope: ModelFit) -> float:
    t = slope.table
    row = t[t["term"] == "lrt_slope"]
    return float(row["p_value"].iloc[0]) if not row.empty else np.nan


def choose_mixed(glmm: ModelFit | None, slope: ModelFit | None,
                 alpha: float = 0.05) -> MixedChoice:
    """Pick the mixed model for the mode contrasts and for the SDs (see the module's rule).

    Parameters
    ----------
    glmm, slope : ModelFit or None
        The intercept-only and the random-slope fits.
    alpha : float
        Level of the LR test of the slope for the SD choice.

    Returns
    -------
    MixedChoice
    """
    if glmm is None or glmm.formula is None:
        return MixedChoice(None, None, np.nan, "no mixed model fitted")
    if slope is None or slope.formula is None:
        why = "; ".join(n for n in (slope.notes if slope is not None else []) if n) or \
            "not fitted"
        return MixedChoice(glmm, glmm, np.nan,
                           f"random-slope model unavailable ({why}): the intercept-only model's "
                           f"mode contrasts ignore any participant variation of the mode effect "
                           f"(under a random slope they covered 0.82-0.88)")
    if slope.formula != glmm.formula:
        return MixedChoice(glmm, glmm, np.nan,
                           f"random-slope model fell back to {slope.formula!r} (the intercept-only "
                           f"model has {glmm.formula!r}): the intercept-only model is used and its "
                           f"mode contrasts ignore any participant variation of the mode effect")
    p = _lrt_p(slope)
    spread = slope if np.isfinite(p) and p < alpha else glmm
    return MixedChoice(slope, spread, p,
                       "random-slope model (1 + mode | participant): mode contrasts from it "
                       "whatever its LR test says; participant SDs from it "
                       + (f"because the LR test of the slope rejects (p = {p:.3f})"
                          if spread is slope else
                          f"only if the LR test of the slope rejects (p = {p:.3f}: "
                          f"intercept-only SD quoted)"))

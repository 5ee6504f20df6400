"""``AnalysisResult``: what :func:`analysis.analyze` computed and wrote, by name."""
from __future__ import annotations

from dataclasses import dataclass, field

import pandas as pd

from .load import TrialLog
from .models import ModelFit

__all__ = ["AnalysisResult"]


@dataclass(kw_only=True)
class AnalysisResult:
    """Everything :func:`analyze` computed and wrote.

    Attributes
    ----------
    log : TrialLog
        The loaded trials (all rows, inclusion marked), sessions and warnings.
    proportions, participants, confusion, contrasts : pandas.DataFrame
        The tables (see :func:`analysis.cell_proportions` etc.).
    gee, bayes : ModelFit
        The GEE and the (demoted, optional) mean-field Bayesian mixed logit.
    glmm : ModelFit
        The mixed logit by maximum likelihood (random intercepts, adaptive
        Gauss-Hermite; :func:`analysis.glmm.fit_glmm`).
    glmm_slope : ModelFit
        The same with a random slope for mode (:func:`analysis.glmm_slope.fit_glmm_slope`).
    tests : pandas.DataFrame
        The named tests: primary, omnibus, per-sample (Holm), interaction.
    chance : pandas.DataFrame
        Tests against chance per cell and per group × mode.
    missing : pandas.DataFrame
        Per participant: scheduled vs answered scored trials, missing ones by reason.
    fidelity : pandas.DataFrame
        Real vs simulated (:func:`analysis.fidelity.mode_contrasts`): averaged per group and
        overall with the equivalence test, per sample with Holm; GEE and mixed-model rows.
    equivalence_margin_pp, equivalence_margin_source : float, str
        The equivalence margin (percentage points) and where it came from.
    mixed_choice : analysis.mixed_choice.MixedChoice
        Which mixed model gave the mode contrasts and the SDs, and why.
    extras : dict of str to pandas.DataFrame
        Information transfer and kappa, Hu, ordinal, covariates, response times.
    summary : str
        Plain-language summary.
    files : dict of str to Path
        Every file written, by name.
    """

    log: TrialLog
    proportions: pd.DataFrame
    participants: pd.DataFrame
    confusion: pd.DataFrame
    gee: ModelFit
    bayes: ModelFit
    contrasts: pd.DataFrame
    summary: str
    files: dict = field(default_factory=dict)
    glmm: ModelFit | None = None
    tests: pd.DataFrame = field(default_factory=pd.DataFrame)
    chance: pd.DataFrame = field(default_factory=pd.DataFrame)
    missing: pd.DataFrame = field(default_factory=pd.DataFrame)
    extras: dict = field(default_factory=dict)
    glmm_slope: ModelFit | None = None
    fidelity: pd.DataFrame = field(default_factory=pd.DataFrame)
    equivalence_margin_pp: float = 10.0
    equivalence_margin_source: str = ""
    mixed_choice: object = None

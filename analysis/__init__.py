"""Analysis of thermocue trial logs: the names an analyst calls.

>>> from analysis import analyze
>>> result = analyze("data", "out")          # doctest: +SKIP
>>> result.proportions, result.contrasts    # doctest: +SKIP

``analysis`` depends on nothing of ``experiments``' runtime: it reads the
session folders (``trials.csv``, ``events.jsonl``, ``session.json``) with
:mod:`sessionfiles.logformat`, the log format shared with the writer (standard library only).
"""
from . import statsmodels_engine
statsmodels_engine.load()     # before any statsmodels model: skips formulaic

from .errors import LogError, LogWarning, ModelWarning  # noqa: E402
from .load import TrialLog, load_trials
from .proportions import cell_proportions, cluster_bootstrap, participant_summary, wilson_interval
from .confusion import confusion_matrices, confusion_matrix
from .models import FORMULA, ModelFit, fit_bayes, fit_gee, group_contrasts
from .glmm import fit_glmm
from .inference import chance_tests, holm, interaction_test, omnibus_group_test
from .figures import plot_confusion, plot_figure9
from .report import analyze
from .result import AnalysisResult
from .power import PowerResult, power_curve
from .fidelity import mode_contrasts, tost
from .mixed_choice import choose_mixed

__all__ = [
    "analyze", "AnalysisResult",
    "load_trials", "TrialLog",
    "cell_proportions", "cluster_bootstrap", "wilson_interval", "participant_summary",
    "confusion_matrices", "confusion_matrix",
    "fit_gee", "fit_glmm", "fit_bayes", "group_contrasts", "ModelFit", "FORMULA",
    "holm", "omnibus_group_test", "interaction_test", "chance_tests",
    "plot_figure9", "plot_confusion",
    "power_curve", "PowerResult",
    "mode_contrasts", "tost", "choose_mixed",
    "LogError", "LogWarning", "ModelWarning",
]

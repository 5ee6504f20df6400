"""Analysis of thermocue trial logs: the names an analyst calls.

>>> from analysis import analyze
>>> result = analyze("data", "out")          # doctest: +SKIP
>>> result.proportions, result.contrasts    # doctest: +SKIP

``analysis`` depends on nothing of ``experiments``' runtime: it reads the
session folders (``trials.csv``, ``events.jsonl``, ``session.json``) with
:mod:`sessionfiles.logformat`, the log format shared with the writer (standard library only).

Each name below is imported from its module when first asked for (``from analysis import
analyze`` imports :mod:`analysis.report` and what it needs): ``import analysis.load`` costs
pandas and the log reader, not SciPy, statsmodels and matplotlib, so that ``thermocue analyze``
can read the sessions in a forked process while it imports the rest (:mod:`.load_ahead`).
The modules that fit statsmodels models load its formula machinery first
(:func:`.statsmodels_engine.load`).
"""
from __future__ import annotations

import importlib
import importlib.util

#: Public name -> submodule defining it.
_EXPORTS = {
    "analyze": "report", "AnalysisResult": "result",
    "load_trials": "load", "TrialLog": "load",
    "cell_proportions": "proportions", "cluster_bootstrap": "proportions",
    "wilson_interval": "proportions", "participant_summary": "proportions",
    "confusion_matrices": "confusion", "confusion_matrix": "confusion",
    "fit_gee": "models", "fit_bayes": "models", "group_contrasts": "models",
    "ModelFit": "models", "FORMULA": "models", "fit_glmm": "glmm",
    "holm": "inference", "omnibus_group_test": "inference", "interaction_test": "inference",
    "chance_tests": "inference",
    "plot_figure9": "figures", "plot_confusion": "figures",
    "power_curve": "power", "PowerResult": "power",
    "mode_contrasts": "fidelity", "tost": "fidelity", "choose_mixed": "mixed_choice",
    "LogError": "errors", "LogWarning": "errors", "ModelWarning": "errors",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str):
    """Load a public name's submodule on first use; a submodule by its name (``analysis.claims``)."""
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    elif importlib.util.find_spec(f"{__name__}.{name}") is not None:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))

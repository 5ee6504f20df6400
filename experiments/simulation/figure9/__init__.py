"""The paper's Figure 9 reproduced: the only part of ``experiments`` (besides the command line) that
imports ``analysis``.

Everything below it in :mod:`experiments.simulation` (the person, the cohort, the observers, the
replay hypotheses, the many-study simulation) is model and runtime; here those meet the analysis:

* :mod:`.study`: the cohort's 30 emulated sessions, then :func:`analysis.analyze` on their logs;
* :mod:`.scenarios`: every (replay hypothesis x observer) scenario against the paper's claims
  (:mod:`analysis.claims`), and the headline's sensitivity;
* :mod:`.reproduction`: ``thermocue reproduce figure9``, both of the above and the figure.

``tests/test_import_layers.py`` holds the rule.
"""
from .study import run_figure9_study, run_participant

__all__ = ["run_figure9_study", "run_participant"]

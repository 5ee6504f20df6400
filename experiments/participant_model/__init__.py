"""The simulated participant: below the session, which its responder serves.

* :mod:`.person`: one simulated participant (skin physics at the receptors, features, noise,
  templates) and :func:`~.person.draw_person`;
* :mod:`.observers`: the named observer family (absolute, relative, range–frequency,
  display-learned): how a percept becomes an answer;
* :mod:`.cohort`: the paper's 30 participants as participant records;
* :mod:`.prediction`: expected proportions correct by Monte Carlo, without sessions.

Nothing here imports the session, the responders or the studies (:mod:`experiments.simulation`,
above the session); ``tests/test_import_layers.py`` holds the rule.
"""
from .observers import OBSERVERS, get_observer

__all__ = ["OBSERVERS", "get_observer"]

"""Simulated participants: the perception model, the paper's cohort, the Figure 9 study, many studies.

* :mod:`.person`: one simulated participant (skin physics at the receptors, features, noise,
  templates) and :func:`~.person.draw_person`;
* :mod:`.prediction`: expected proportions correct by Monte Carlo, without sessions;
* :mod:`.cohort`: the paper's 30 participants as participant records;
* :mod:`.figure9`: the Figure 9 study, its scenarios against the paper's claims and
  ``reproduce figure9`` (the one package of ``experiments``, besides the command line, that
  imports ``analysis``);
* :mod:`.observers`: the named observer family (absolute, relative, range–frequency,
  display-learned);
* :mod:`.replay`: the replay hypotheses as protocol variants (material side = printed Eq. 7,
  skin side, compensated);
* :mod:`.studies`: thousands of simulated 15 + 15 studies from the same person and observer
  models, for the paper's claims (evaluated in :mod:`.figure9.scenarios`).
"""
from .observers import OBSERVERS, get_observer
from .replay import REPLAY_HYPOTHESES, protocol_variant, replay_hypothesis

__all__ = ["OBSERVERS", "get_observer", "REPLAY_HYPOTHESES", "protocol_variant",
           "replay_hypothesis"]

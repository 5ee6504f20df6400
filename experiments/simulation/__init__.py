"""Simulated participants beyond one session: observer models, replay hypotheses, many studies.

* :mod:`.observers`: the named observer family (absolute, relative, range–frequency,
  display-learned);
* :mod:`.replay`: the replay hypotheses as protocol variants (material side = printed Eq. 7,
  skin side, compensated);
* :mod:`.studies`: thousands of simulated 15 + 15 studies from the same person and observer
  models, for the paper's claims (:mod:`analysis.claims`).
"""
from .observers import OBSERVERS, get_observer
from .replay import REPLAY_HYPOTHESES, protocol_variant, replay_hypothesis

__all__ = ["OBSERVERS", "get_observer", "REPLAY_HYPOTHESES", "protocol_variant",
           "replay_hypothesis"]

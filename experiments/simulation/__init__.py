"""Simulated studies, above the session: the replay hypotheses, many studies, Figure 9.

* :mod:`.replay`: the replay hypotheses (what the paper's display played) as protocol variants;
* :mod:`.studies`: thousands of simulated 15 + 15 studies from the participant model
  (:mod:`experiments.participant_model`);
* :mod:`.sweep`: those studies (and the study's sessions) on ``dask.distributed``;
* :mod:`.figure9`: the Figure 9 study, its scenarios against the paper's claims and
  ``reproduce figure9`` (the one package of ``experiments``, besides the command line, that
  imports ``analysis``).

The participant model itself (person, observers, cohort, prediction) is
:mod:`experiments.participant_model`, below the session.
"""
from .replay import REPLAY_HYPOTHESES, protocol_variant, replay_hypothesis

__all__ = ["REPLAY_HYPOTHESES", "protocol_variant", "replay_hypothesis"]

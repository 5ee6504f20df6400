"""The bounds a protocol is checked against: the skin-safe display range and the upper limits
that keep any value from hanging or overflowing a session.

One concept, the protocol's ranges; ``protocol.schema.json`` states them as its bounds
(``tests/experiments/test_validation_stack.py`` checks the two agree), and
:mod:`experiments.protocol.build` uses :data:`MAX_TRIALS`.
"""
from __future__ import annotations

#: Skin-safe bounds of ``[display]`` min_C, max_C and neutral_C (°C).  The pad touches a
#: fingertip for up to ``max_contact_s``: 45 °C is where heat pain begins for most people (the
#: heat-pain threshold region, ~43-47 °C, and the usual ceiling of thermal testers held against
#: skin), and below ~5 °C contact cooling turns painful and risks cold injury.  The paper's range
#: (15-42 °C, the packaged protocols) lies well inside; the device's own hard range may be wider.
SKIN_SAFE_MIN_C = 5.0
SKIN_SAFE_MAX_C = 45.0

#: Upper bounds, so that no value can hang or overflow a session: ids and versions,
MAX_ID = 1_000_000
#: presentations of one sample in a block, trials in a whole session,
MAX_REPETITIONS = 1000
MAX_TRIALS = 5000
#: and any wait (contact time-out, rewarming), s.
MAX_WAIT_S = 3600.0
#: Why a wait is bounded, and why a skin thickness is (the ``why`` of the error message).
WAIT_WHY = "at most an hour: longer is a typo, and a real clock cannot wait it"
SKIN_WHY = "µm of fingertip skin: at most 1 cm"

"""One lab for every simulated touch: contact force and skin temperature, per touch.

The emulated study's simulated participants (:class:`experiments.responders.simulated.
SimulatedResponder`), the Monte Carlo of many studies (:func:`experiments.simulation.studies.
simulate_studies`) and its sensitivity rows all draw a touch's force and skin temperature from
:class:`LabVariability` (:data:`DEFAULT_LAB` unless told otherwise), so that the × markers of the
emulated study and the distributions of the simulated ones come from the same lab
(``tests/experiments/participant_model/test_lab.py`` checks it with a two-sample test).

Contact force.  The paper's participants were "trained to contact samples with about 2 N"
(§3.2), and the display (the paper's and the emulated one) starts a contact when the summed
force crosses the protocol's ``[contact] force_threshold_N`` (2 N): a touch that stays below
never starts a trial, so every logged touch presses harder than 2 N.  The lab presses at
2.5 ± 0.25 N (normal; the spread is an assumption, the paper gives none), clipped to
:data:`FORCE_RANGE_N` (just past the trigger to 3 N).

Skin temperature.  Between participants uniform over the paper's 35.5-36 °C; within a
participant, normal about the participant's own with ``skin_temperature_sd_C`` per touch
(:attr:`~.person.PerceptionParameters.skin_temperature_sd_C`'s default, 0.1 K).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stimuli.paper import SKIN_TEMPERATURE_RANGE_C

from .person import PerceptionParameters

__all__ = ["LabVariability", "DEFAULT_LAB", "FORCE_RANGE_N", "FORCE_TRIGGER_N"]

#: Summed force at which the display starts a contact (the protocol's force_threshold_N), N.
FORCE_TRIGGER_N = 2.0
#: Forces a logged touch can have, N: just past the trigger, up to 3 N.
FORCE_RANGE_N = (2.05, 3.0)


@dataclass(frozen=True)
class LabVariability:
    """Variability of people and touches across and within simulated studies.

    Parameters
    ----------
    force_sd_N : float, N
        Per-touch contact force: normal about ``force_N`` with this spread, clipped to
        :data:`FORCE_RANGE_N` (0: every touch at ``force_N``).
    force_N : float, N
        The lab's mean press (2.5 N: above the 2 N trigger, see the module).
    skin_temperature_sd_C : float, K
        Per-touch skin temperature about the participant's own (within participant).
    skin_temperature_C : (low, high), °C
        Participants' skin temperatures, uniform (between participants; the paper's 35.5-36).
    cohort_size : int or None
        None: a fresh cohort for every study; else one cohort of this many persons per group
        that every study draws 15 from without replacement.
    """

    force_sd_N: float = 0.25
    force_N: float = 2.5
    skin_temperature_sd_C: float = PerceptionParameters.skin_temperature_sd_C
    skin_temperature_C: tuple = SKIN_TEMPERATURE_RANGE_C
    cohort_size: int | None = None

    def __post_init__(self):
        lo, hi = FORCE_RANGE_N
        if not (0 <= self.force_sd_N <= 2.0):
            raise ValueError(f"LabVariability: force_sd_N: expected 0-2 N, got {self.force_sd_N!r}")
        if not (lo <= self.force_N <= hi):
            raise ValueError(f"LabVariability: force_N: expected {lo:g}-{hi:g} N (a touch must "
                             f"cross the {FORCE_TRIGGER_N:g} N trigger), got {self.force_N!r}")
        if not (0 <= self.skin_temperature_sd_C <= 2.0):
            raise ValueError(f"LabVariability: skin_temperature_sd_C: expected 0-2 K, got "
                             f"{self.skin_temperature_sd_C!r}")

    def draw_forces(self, rng: np.random.Generator, shape=()) -> np.ndarray:
        """Contact forces of touches, N: normal, clipped to :data:`FORCE_RANGE_N`."""
        return np.clip(self.force_N + self.force_sd_N * rng.standard_normal(shape), *FORCE_RANGE_N)

    def draw_skin_temperatures(self, rng: np.random.Generator, own_C, shape=()) -> np.ndarray:
        """Skin temperatures of touches about the participant's own ``own_C``, °C."""
        return np.asarray(own_C) + self.skin_temperature_sd_C * rng.standard_normal(shape)

    def to_dict(self) -> dict:
        """JSON-ready, unit-suffixed."""
        return {"force_N": self.force_N, "force_sd_N": self.force_sd_N,
                "force_range_N": list(FORCE_RANGE_N),
                "skin_temperature_sd_C": self.skin_temperature_sd_C,
                "skin_temperature_range_C": list(self.skin_temperature_C),
                "cohort": "fresh per study" if self.cohort_size is None else
                          f"one cohort of {self.cohort_size} per group"}


#: The lab every simulated touch comes from by default.
DEFAULT_LAB = LabVariability()

"""The simulated trials' target profiles during a run, and the scene planner's word on them.

Every profile of the schedule is computed and checked before the session writes anything
(:func:`experiments.session.setup.check_schedule_profiles`); :class:`SessionProfiles` holds
those, computes any other on demand (:func:`experiments.session.setup.simulated_target_profile`),
checks them against an open display's capacity, and tells the experimenter the planner's
decisions once per profile.
"""
from __future__ import annotations

from experiments.session.setup import check_capacity, simulated_target_profile

__all__ = ["SessionProfiles"]


class SessionProfiles:
    """The checked target profiles of one session, keyed by ``(roughness_id, roughness_um)``.

    Parameters
    ----------
    profiles : dict, optional
        Profiles already computed and checked (:func:`check_schedule_profiles`).
    """

    def __init__(self, profiles: dict | None = None):
        self.profiles = dict(profiles or {})
        self._told: set = set()   # profiles whose model decisions the experimenter was told

    def check_display(self, protocol, display, source: str) -> None:
        """The profiles against an open display's capacity (points, step): ProtocolError."""
        check_capacity(protocol, self.profiles, display, source)

    def target(self, session, spec, say):
        """The target profile of a simulated trial of ``session``; ``say`` gets the planner's
        decisions the first time a profile is used."""
        key = (spec.roughness_id, spec.roughness_um)
        if key not in self.profiles:
            self.profiles[key] = simulated_target_profile(
                session.protocol, session.participant, session.group, None, spec.roughness_id, spec.roughness_um)
        if key not in self._told:
            from stimuli.planner import plan_line
            self._told.add(key)
            say(f"profile {spec.roughness_id}# ({spec.roughness_um:g} um): "
                + plan_line(self.profiles[key].parameters.get("plan")))
        return self.profiles[key]

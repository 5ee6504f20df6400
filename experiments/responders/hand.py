"""The emulated hand: what a person's hand does on the bench, scripted on the emulator.

On a real trial the experimenter places the sample on the bench; on every trial the finger
approaches, presses with a force, stays and lets go. On the emulator
(:class:`~experiments.display.base.EmulatedDisplay`) both are scripted here, once, for the
session's stand-in hand (:meth:`experiments.session.Session.emulated_touch`), the simulated
participant (:meth:`experiments.responders.simulated.SimulatedResponder.touch`), the PsychoPy
cue's dry run (:meth:`experiments.psychopy_plugin.cue.ThermalCue.start`) and the display bench
(:mod:`experiments.bench.display`).
"""
from __future__ import annotations

__all__ = ["press", "finger_model"]


def press(display, *, sample: dict | None, press_after_s: float, hold_s: float,
          force_N: float | None = None, skin_thickness_m: float | None = None,
          skin_temperature_C: float | None = None) -> dict:
    """Place ``sample`` on the bench (a real trial; None on a simulated one) and press the finger.

    Parameters
    ----------
    display : EmulatedDisplay
    sample : dict or None
        ``material``, ``roughness_m`` (m), ``thickness_m`` (m), ``temperature_C`` (°C).
    press_after_s : float, s
        From arming to the press.
    hold_s : float, s
        How long the finger stays on.
    force_N : float, N, optional
    skin_thickness_m : float, m, optional
    skin_temperature_C : float, °C, optional
        The press and the finger's skin; not given, the emulator's own default finger (its
        ``sim_finger`` defaults: 2 N, 650 µm, 35.5 °C) presses.

    Returns
    -------
    dict
        The emulator's ``sim_finger`` reply (:func:`finger_model` reads what models the touch).
    """
    if sample is not None:
        display.sim_sample(material=sample["material"], roughness_m=sample["roughness_m"],
                           thickness_m=sample["thickness_m"], temperature_C=sample["temperature_C"])
    finger = dict(force_N=force_N, skin_thickness_m=skin_thickness_m, skin_temperature_C=skin_temperature_C)
    reply = display.sim_finger(press_after_s=press_after_s, hold_s=hold_s,
                               **{k: v for k, v in finger.items() if v is not None})
    return reply if isinstance(reply, dict) else {}


def finger_model(reply: dict) -> dict | None:
    """What models the emulated finger's touch, from a :func:`press` reply (None if not said).

    ``{"sample_model": {side: decision}}`` on a real trial (the scene planner's decision for each
    side of the passive sample's interface: model, method, tolerance_K, bound_K, kept,
    neglected), ``{"finger_on_pad_model": ...}`` on a played one; logged by the session as the
    ``emulated_finger_model`` event.
    """
    out = {k: reply[k] for k in ("sample_model", "finger_on_pad_model") if k in (reply or {})}
    return out or None

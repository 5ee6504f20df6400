"""The emulated hand: what a person's hand does on the bench, scripted on the emulator.

On a real trial the experimenter places the sample on the bench; on every trial the finger
approaches, presses with a force, stays and lets go. On the emulator
(:class:`~experiments.session.display.EmulatedDisplay`) both are scripted here, once, for the
session's stand-in hand (:meth:`experiments.session.Session.emulated_touch`) and for the
simulated participant (:meth:`experiments.responders.simulated.SimulatedResponder.touch`).
"""
from __future__ import annotations

__all__ = ["press"]


def press(display, *, sample: dict | None, press_after_s: float, force_N: float, hold_s: float,
          skin_thickness_m: float, skin_temperature_C: float) -> None:
    """Place ``sample`` on the bench (a real trial; None on a simulated one) and press the finger.

    Parameters
    ----------
    display : EmulatedDisplay
    sample : dict or None
        ``material``, ``roughness_m`` (m), ``thickness_m`` (m), ``temperature_C`` (°C).
    press_after_s : float, s
        From arming to the press.
    force_N : float, N
    hold_s : float, s
        How long the finger stays on.
    skin_thickness_m : float, m
    skin_temperature_C : float, °C
    """
    if sample is not None:
        display.sim_sample(material=sample["material"], roughness_m=sample["roughness_m"],
                           thickness_m=sample["thickness_m"], temperature_C=sample["temperature_C"])
    display.sim_finger(press_after_s=press_after_s, force_N=force_N, hold_s=hold_s,
                       skin_thickness_m=skin_thickness_m, skin_temperature_C=skin_temperature_C)

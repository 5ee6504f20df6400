"""The simulated-material profile on a resting probe (``[simulation] contact_model = "resting"``).

The paper's display is touched: the pad waits at the profile's first sample (the interface
temperature of the first instant, e.g. 20 °C for a steel sample's material side) and the finger
presses onto it, so the skin meets that temperature at once, as it meets a real sample. A
thermode such as the QST.Lab TCS II rests on the skin before the stimulation: the skin under it
is at the probe's neutral temperature, and the stimulus cannot jump -- it starts at the skin
temperature and can approach the target no faster than the protocol's rate limit.
:func:`resting_profile` gives that profile: it starts at the skin temperature, moves towards the
target at the rate limit (less the rounding's share) and follows the target once it has met it.
The first fraction of a second of a real touch -- the fastest, most informative change -- is
therefore replaced by a ramp; ``docs/tcs2.md`` shows both profiles for 1# and 4#.
"""
from __future__ import annotations

import numpy as np

__all__ = ["resting_profile"]


def resting_profile(target_C, dt_s: float, skin_C: float, max_rate_C_per_s: float, *,
                    window_s: float = 0.1, resolution_C: float = 0.01) -> tuple:
    """The target as a probe resting on the skin can play it, and how far it departs.

    Parameters
    ----------
    target_C : array_like, °C
        The press-to-touch target, uniformly sampled from the contact.
    dt_s : float, s
        Its step.
    skin_C : float, °C
        Where the probe (and the skin under it) is when stimulation starts.
    max_rate_C_per_s : float, °C/s
        The protocol's rate limit; the ramp runs at it less ``resolution_C / window_s`` so that
        rounding cannot push it over the display's check.
    window_s, resolution_C : float
        The display's rate window (s) and setpoint resolution (°C).

    Returns
    -------
    profile : ndarray, °C
        Starts at ``skin_C`` (rounded to ``resolution_C``), never faster than the limit.
    max_change_C : float, K
        ``max |profile - target|`` (the early part of the touch given up).
    catch_up_s : float, s
        When the profile first meets the target (within ``resolution_C``); the duration if never.
    """
    x = np.asarray(target_C, dtype=float)
    if not (dt_s > 0 and max_rate_C_per_s > resolution_C / window_s):
        raise ValueError(f"resting_profile: expected dt_s > 0 and max_rate_C_per_s > "
                         f"{resolution_C / window_s:g}, got {dt_s!r}, {max_rate_C_per_s!r}")
    step = (max_rate_C_per_s - resolution_C / window_s) * dt_s
    y = np.empty_like(x)
    y[0] = round(skin_C / resolution_C) * resolution_C
    met = None
    for i in range(1, x.size):
        lo, hi = y[i - 1] - step, y[i - 1] + step
        y[i] = lo if x[i] < lo else hi if x[i] > hi else x[i]
        if met is None and abs(y[i] - x[i]) <= resolution_C:
            met = i
    y = np.round(y / resolution_C) * resolution_C
    y[0] = round(skin_C / resolution_C) * resolution_C
    catch_up = (met if met is not None else x.size - 1) * dt_s
    return y, float(np.max(np.abs(y - x))), float(catch_up)

r"""Duhamel superposition of a piecewise-linear boundary history on a uniform time grid.

A linear, time-invariant system with unit-step response S(t) (S(0) = 0) driven by a boundary
value h(t) that jumps from 0 to h_0 at t = 0 and is linear between samples h_j at t_j = j Δ has

.. math::

   u(t_i) = h_0 S(t_i) + \sum_{j<i} s_j\,[R(t_i - t_j) - R(t_i - t_{j+1})],
   \qquad s_j = (h_{j+1} - h_j)/Δ,\quad R(t) = \int_0^t S,

exactly. Writing R(t) = g t + R_rest(t), where g = S(∞) is the static gain, the linear part
sums to g (h_i - h_0) and the rest is a discrete convolution of the slopes with
E_m = R_rest(t_m) - R_rest(t_{m-1}), done by FFT: O(N log N) for N samples.
"""
from __future__ import annotations

import numpy as np

__all__ = ["superpose"]


def superpose(h: np.ndarray, dt: float, S: np.ndarray, R_rest: np.ndarray, gain: float,
              tail=None) -> np.ndarray:
    """Return u(t_i) for the piecewise-linear history ``h`` (see the module docstring).

    Parameters
    ----------
    h : ndarray
        Boundary values at t_i = i dt (any unit; u has the same unit).
    dt : float, s
    S : ndarray, dimensionless
        Step response at the same t_i (S[0] is ignored: u(0) = h_0 * S[0] is returned as given).
    R_rest : ndarray, s
        R(t_i) - gain * t_i, with R_rest[0] = 0.
    gain : float, dimensionless
        Static gain g.
    tail : tuple or None
        ``(m0, rates, k)``: for t >= t_{m0 - 1}, R_rest(t) = const + sum_n k_n exp(-rates_n t)
        (rates in 1/s). The convolution is then split: lags m < m0 by FFT, lags m >= m0 by one
        exact first-order recursion per mode (``scipy.signal.lfilter``), which is cheaper when
        m0 is much shorter than the record.

    Returns
    -------
    ndarray
    """
    from scipy.signal import fftconvolve, lfilter    # ~0.5 s to import: not at `import stimuli`
    h = np.asarray(h, dtype=float)
    u = h[0] * S + gain * (h - h[0])
    if h.size > 1:
        slopes = np.diff(h) / dt
        E = np.diff(R_rest)
        if not np.any(slopes):
            return u
        n = slopes.size
        if tail is None or tail[0] >= n:
            u[1:] += fftconvolve(E, slopes)[:n]
            return u
        m0, rates, k = tail
        # lags 1 .. m0-1 (E[0 .. m0-2]) by FFT
        u[1:] += fftconvolve(E[: m0 - 1], slopes)[:n]
        # lags m >= m0: E_m = sum_n A_n r_n^m with r_n = exp(-rate_n dt)
        for rate, kn in zip(rates, k):
            r = np.exp(-rate * dt)
            A = kn * -np.expm1(rate * dt)          # k (r^m - r^(m-1)) = k (1 - 1/r) r^m
            y = lfilter([1.0], [1.0, -r], slopes[: n - m0 + 1])
            u[m0:] += (A * r ** m0) * y
    return u

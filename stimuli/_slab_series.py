r"""Exact step and ramp responses of a homogeneous slab with a prescribed surface temperature.

Slab 0 < x < L, diffusivity alpha, u(0, t) = 0, u(x, 0) = 0 and u(L, t) = 1 for t > 0.
With xi = x / L and tau = alpha t / L^2 the step response is (Carslaw & Jaeger [1]_, §3.4)

.. math::

   S = \sum_{n\ge0} \operatorname{erfc}\frac{2n+1-\xi}{2\sqrt\tau}
       - \operatorname{erfc}\frac{2n+1+\xi}{2\sqrt\tau}
     = \xi + \frac{2}{\pi}\sum_{n\ge1}\frac{(-1)^n}{n}\sin(n\pi\xi)\,e^{-n^2\pi^2\tau},

the image series converging fast for small tau, the eigenfunction series for large tau. The
ramp response R(t) = \int_0^t S uses :math:`\int_0^\tau \operatorname{erfc}(a/2\sqrt{\tau'})
d\tau' = 4\tau\,i^2\operatorname{erfc}(a/2\sqrt\tau)` and, in the eigen form,
:math:`\sum_{n\ge1}(-1)^n\sin(n\pi\xi)/n^3 = -\pi^3(\xi-\xi^3)/12`:

.. math::

   R - \xi t = -\frac{L^2}{\alpha}\Big[\frac{\xi-\xi^3}{6}
       + \frac{2}{\pi^3}\sum_{n\ge1}\frac{(-1)^n}{n^3}\sin(n\pi\xi)\,e^{-n^2\pi^2\tau}\Big].

Both series are truncated where the next term is below 1e-17 (relative); the switch between
them is at tau = 1/4, where each needs at most five terms.

References
----------
.. [1] H. S. Carslaw, J. C. Jaeger, Conduction of Heat in Solids, 2nd ed., Oxford 1959, §3.4.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.special import erfcx

__all__ = ["step_and_ramp", "first_image_term", "ramp_modes", "TAU_SWITCH", "TAU_TAIL"]

#: tau = alpha t / L^2 below which the image series is used.
TAU_SWITCH = 0.25
#: tau beyond which R - xi t is taken as two decaying modes: mode 3 is below e^-35 = 6e-16 of its
#: amplitude there (n^2 pi^2 tau > _TAIL_EXPONENT for n >= 3).
TAU_TAIL = 0.4
_TAIL_EXPONENT = 32.0
_ZMAX = 6.5          # erfc(6.5) = 3.8e-20: image terms with larger arguments are dropped
_EIG_EXPONENT = 45.0  # modes with n^2 pi^2 tau > 45 (e^-45 = 3e-20) are dropped
_SQRT_PI = math.sqrt(math.pi)


def _i2erfc_and_erfc(z):
    """Return (4 i^2erfc(z), erfc(z)) for z >= 0 via erfcx (no overflow, no cancellation blow-up)."""
    ez = np.exp(-z * z)
    ex = erfcx(z)
    return ez * ((1.0 + 2.0 * z * z) * ex - 2.0 * z / _SQRT_PI), ez * ex


def _image(xi, tau, n_terms, first=0):
    """Image-series S and R/(L^2/alpha) = 4 tau sum(i2erfc) for tau > 0 (sorted ascending)."""
    S = np.zeros_like(tau)
    Rn = np.zeros_like(tau)
    sq = 2.0 * np.sqrt(tau)
    for n in range(first, n_terms):
        a = 2 * n + 1 - xi
        # the term matters only where a / (2 sqrt tau) < ZMAX, a suffix of the sorted times
        start = int(np.searchsorted(tau, (a / (2.0 * _ZMAX)) ** 2, side="left"))
        if start >= tau.size:
            continue
        sl = slice(start, None)
        ia, ea = _i2erfc_and_erfc(a / sq[sl])
        ib, eb = _i2erfc_and_erfc((2 * n + 1 + xi) / sq[sl])
        S[sl] += ea - eb
        Rn[sl] += tau[sl] * (ia - ib)
    return S, Rn


def step_and_ramp(xi: float, tau: np.ndarray, diffusion_time: float):
    """Exact unit-step response S and ramp remainder R - xi t of the slab at ``xi``.

    Parameters
    ----------
    xi : float, dimensionless
        Depth x / L, 0 <= xi <= 1.
    tau : ndarray, dimensionless
        alpha t / L^2, sorted ascending, >= 0.
    diffusion_time : float, s
        L^2 / alpha (converts the ramp integral to seconds).

    Returns
    -------
    S : ndarray, dimensionless
        Step response (0 at tau = 0 for xi < 1).
    R_rest : ndarray, s
        :math:`\\int_0^t S\\,dt' - \\xi t` (0 at tau = 0).
    """
    tau = np.asarray(tau, dtype=float)
    S = np.zeros_like(tau)
    Rr = np.zeros_like(tau)
    if xi >= 1.0:
        S[tau > 0] = 1.0
        return S, Rr
    if xi <= 0.0:
        return S, Rr
    i_sw = int(np.searchsorted(tau, TAU_SWITCH, side="left"))
    pos = int(np.searchsorted(tau, 0.0, side="right"))
    if i_sw > pos:
        t_img = tau[pos:i_sw]
        n_img = int(math.floor((2.0 * _ZMAX * math.sqrt(TAU_SWITCH) + xi - 1.0) / 2.0)) + 1
        s_i, r_i = _image(xi, t_img, max(n_img, 1))
        S[pos:i_sw] = s_i
        Rr[pos:i_sw] = diffusion_time * r_i - xi * diffusion_time * t_img
    if i_sw < tau.size:
        t_eig = tau[i_sw:]
        n_max = int(math.ceil(math.sqrt(_EIG_EXPONENT / (math.pi ** 2 * t_eig[0]))))
        s_e = np.full_like(t_eig, xi)
        r_e = np.full_like(t_eig, -(xi - xi ** 3) / 6.0)
        for n in range(1, n_max + 1):
            lam = (n * math.pi) ** 2
            stop = int(np.searchsorted(t_eig, _EIG_EXPONENT / lam, side="right"))
            if stop == 0:
                break
            e = np.exp(-lam * t_eig[:stop])
            sgn_sin = (-1.0) ** n * math.sin(n * math.pi * xi)
            s_e[:stop] += (2.0 / math.pi) * sgn_sin / n * e
            r_e[:stop] -= (2.0 / math.pi ** 3) * sgn_sin / n ** 3 * e
        S[i_sw:] = s_e
        Rr[i_sw:] = diffusion_time * r_e
    return S, Rr


def first_image_term(xi: float, tau: np.ndarray, diffusion_time: float, *, rest: bool = False):
    """S and R - xi t from the n = 0 image term only (``rest=False``) or from all n >= 1 (``rest=True``).

    The n = 0 term is the paper's Eq. 8 in the display limit (beta_M -> inf, R = 0); the rest is
    what it neglects. Same units as :func:`step_and_ramp`.
    """
    tau = np.asarray(tau, dtype=float)
    S = np.zeros_like(tau)
    Rr = np.zeros_like(tau)
    if xi >= 1.0:
        if not rest:
            S[tau > 0] = 1.0
        return S, Rr
    if xi <= 0.0:
        return S, Rr
    pos = int(np.searchsorted(tau, 0.0, side="right"))
    t = tau[pos:]
    if rest:
        # terms n >= 1 up to where they vanish at the largest time
        n_img = int(math.floor((2.0 * _ZMAX * math.sqrt(t[-1]) + xi - 1.0) / 2.0)) + 1 if t.size else 1
        s, r = _image(xi, t, max(n_img, 1), first=1)
    else:
        s, r = _image(xi, t, 1)
    S[pos:] = s
    Rr[pos:] = diffusion_time * r - xi * diffusion_time * t
    return S, Rr


def ramp_modes(xi: float, tau_from: float, diffusion_time: float):
    """Modes of R - xi t for tau >= ``tau_from``: R - xi t = c0 + sum_n k_n exp(-n^2 pi^2 tau).

    Returns ``(c0, rates, k)``: c0 in s, ``rates`` n^2 pi^2 (per unit tau), ``k`` in s, keeping
    the modes with n^2 pi^2 tau_from <= 32 (the rest are below 1.3e-14 relative, and their
    amplitudes k_n fall as 1/n^3).
    """
    c0 = -diffusion_time * (xi - xi ** 3) / 6.0
    n_max = max(1, int(math.floor(math.sqrt(_TAIL_EXPONENT / (math.pi ** 2 * tau_from)))))
    n = np.arange(1, n_max + 1)
    rates = (n * math.pi) ** 2
    k = -diffusion_time * (2.0 / math.pi ** 3) * (-1.0) ** n * np.sin(n * math.pi * xi) / n ** 3
    return c0, rates, k

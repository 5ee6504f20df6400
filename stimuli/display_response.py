r"""The receptor response to a display-imposed surface temperature (DESIGN.md ``skin_response``).

On a simulated trial the display imposes a temperature history g(t) on the skin surface x = L;
the skin 0 < x < L starts uniform at T_S0 and stays at T_S0 at x = 0. In the Laplace domain
(DESIGN.md) :math:`\hat\theta_S = 1/s + (G(s) - 1/s)\,\sinh(q_S x)/\sinh(q_S L)`; in the time
domain the response at depth x is Duhamel's superposition of the slab's exact unit-step
response S(x, t) over the piecewise-linear history (:mod:`stimuli._slab_series`,
:mod:`stimuli._duhamel`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _slab_series as series
from ._duhamel import superpose
from .errors import ModelInputError
from .finite_volume import DEFAULT_CELLS, _check_depth, _uniform_times, solve_surface

__all__ = ["skin_response", "ResponseInfo", "METHODS"]

#: Methods accepted by :func:`skin_response`.
METHODS = ("exact", "paper", "paper-as-printed", "numerical")
_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class ResponseInfo:
    """What :func:`skin_response` computed (returned with ``full_output=True``).

    Attributes
    ----------
    method : str
        The method used (the one asked for, or the one ``tolerance`` picked).
    error_bound : float, K
        Bound on max |returned - exact solution| for the piecewise-linear history
        (for ``"numerical"``: |difference of two Richardson extrapolations|, a conservative
        estimate, not a strict bound).
    cells : int or None
        Finite-volume grid resolution, for ``"numerical"``.
    """

    method: str
    error_bound: float
    cells: int | None = None


def _history(t, surface_temperature, initial_temperature, where):
    t, dt = _uniform_times(t, where)
    g = np.asarray(surface_temperature, dtype=float)
    if g.shape != t.shape or not np.all(np.isfinite(g)):
        raise ModelInputError(f"{where}: surface_temperature: expected {t.size} finite values in °C "
                              f"(one per time), got shape {g.shape!r}")
    try:
        T0 = float(initial_temperature)
    except (TypeError, ValueError):
        T0 = float("nan")
    if not math.isfinite(T0):
        raise ModelInputError(f"{where}: initial_temperature: expected a finite °C, got {initial_temperature!r}")
    return t, dt, g - T0, T0


def _variation(h):
    return abs(float(h[0])) + float(np.sum(np.abs(np.diff(h))))


def _series_response(skin, t, dt, h, xi, kernel, tail=False):
    T_diff = skin.thickness ** 2 / skin.diffusivity
    S, R_rest = kernel(xi, t / T_diff, T_diff)
    modes = None
    if tail and dt > 0:
        # lags with t_{m-1} >= TAU_TAIL L^2/alpha: R - xi t is two exact modes (recursions)
        m0 = int(math.ceil(series.TAU_TAIL * T_diff / dt)) + 1
        _, rates, k = series.ramp_modes(xi, series.TAU_TAIL, T_diff)
        modes = (m0, rates / T_diff, k)
    return superpose(h, dt, S, R_rest, xi, tail=modes)


def _exact(skin, t, dt, h, xi):
    u = _series_response(skin, t, dt, h, xi, series.step_and_ramp, tail=True)
    # kernels are exact to ~1e-17; FFT convolution rounding ~ eps log2(n) |E|_2 |s|_2 (tiny)
    bound = float(1e-12 * max(1.0, _variation(h)) + 4.0 * _EPS * float(np.max(np.abs(h))))
    return u, bound


def _paper_bound(skin, t, h, xi):
    """max |S - S_0| on [0, t_max] times (|h_0| + TV(h)): bound for the n = 0 image form."""
    T_diff = skin.thickness ** 2 / skin.diffusivity
    probe = np.linspace(0.0, float(t[-1]), 257)
    rest, _ = series.first_image_term(xi, probe / T_diff, T_diff, rest=True)
    return float(np.max(np.abs(rest))) * _variation(h) + 1e-12 * max(1.0, _variation(h))


def _paper(skin, t, dt, h, xi):
    u = _series_response(skin, t, dt, h, xi, series.first_image_term)
    return u, _paper_bound(skin, t, h, xi)


def _printed(skin, t, dt, h, xi):
    # Eq. 8 as printed has the prefactor (1 + gamma)/2; a display is the beta_M -> inf limit of a
    # material, gamma = (beta_S - beta_M)/(beta_S + beta_M) -> -1: the printed response vanishes.
    u = np.zeros_like(h)
    T_diff = skin.thickness ** 2 / skin.diffusivity
    probe = np.linspace(0.0, float(t[-1]), 257)
    S, _ = series.step_and_ramp(xi, probe / T_diff, T_diff)
    return u, float(np.max(np.abs(S))) * _variation(h)


def _numerical(skin, t, h, x, cells, epidermis_properties, T0):
    """Finite volumes on the ``cells`` grid and its exact 2x and 4x bisections, extrapolated.

    The spatial error is c2 h^2 + c4 h^4 + ... on self-similar grids, so r1 = (4 u2 - u1)/3 and
    r2 = (4 u4 - u2)/3 are fourth-order and r2's error is about |r2 - r1| / 15; |r2 - r1| is
    returned as a conservative estimate.
    """
    u1, u2, u4 = (solve_surface(skin, t, h + T0, T0, x, cells=cells, split=k,
                                epidermis_properties=epidermis_properties) - T0 for k in (1, 2, 4))
    r1 = (4.0 * u2 - u1) / 3.0
    r2 = (4.0 * u4 - u2) / 3.0
    return r2, float(np.max(np.abs(r2 - r1)))


def skin_response(skin, t, surface_temperature, initial_temperature=35.0, depth=None,
                  method="exact", tolerance=None, *, epidermis_properties=None,
                  cells=DEFAULT_CELLS, full_output=False):
    r"""Skin temperature at one depth while a display imposes the surface temperature.

    Parameters
    ----------
    skin : Skin
        Thickness L, dermis d (receptor depth), properties.
    t : array_like, s
        Uniform times starting at 0 (the samples of the display profile).
    surface_temperature : array_like, °C
        The imposed surface temperature at each ``t``, linear in between; before t = 0 the
        skin is uniform at ``initial_temperature`` and the surface jumps to
        ``surface_temperature[0]`` at t = 0.
    initial_temperature : float, °C
        T_S0, also held at the inner boundary x = 0.
    depth : float or None, m
        From the inner boundary (0 <= depth <= L); ``None``: the receptors, ``skin.dermis``.
    method : {"exact", "paper", "paper-as-printed", "numerical"}
        ``"exact"``: Duhamel superposition of the exact slab step response (image series for
        alpha t / L^2 < 1/4, eigenfunction series after), O(N log N) by FFT;
        ``"paper"``: the same with the paper's closed form, the n = 0 image term of Eq. 8 in the
        display limit (beta_M -> inf, R = 0, corrected prefactor (1 - gamma)/2 -> 1);
        ``"paper-as-printed"``: Eq. 8 as printed, whose prefactor (1 + gamma)/2 vanishes in that
        limit, so the receptor never moves (kept to show the printed error);
        ``"numerical"``: the finite-volume solver (:func:`stimuli.finite_volume.solve_surface`)
        on the ``cells`` grid and its exact 2x and 4x bisections, Richardson-extrapolated (fourth
        order); the only method for layered skin.
    tolerance : float or None, K
        If given, ``method`` is ignored and the cheapest method whose error bound is within
        ``tolerance`` is used: "exact" for homogeneous skin (the paper's form costs as much and
        is less accurate), "numerical" with grid doubling until its estimate is within
        ``tolerance`` for layered skin; ``full_output`` reports which.
    epidermis_properties : Layer or Material-like or None, keyword-only
        Different epidermis properties (``"numerical"`` only).
    cells : int, keyword-only
        Base grid resolution for ``"numerical"``.
    full_output : bool, keyword-only
        Also return a :class:`ResponseInfo` (method used, error bound in K).

    Returns
    -------
    T : ndarray, °C
        Temperature at ``depth`` at each ``t``.
    info : ResponseInfo
        Only with ``full_output=True``.

    Raises
    ------
    ModelInputError
        Non-uniform or non-zero-based times, a length mismatch, non-finite temperatures, a depth
        outside [0, L], an unknown method, a tolerance <= 0 or one no method can meet.

    Notes
    -----
    For a unit surface step the slab's response at x = xi L is the image series
    :math:`S=\sum_{n\ge0}\operatorname{erfc}\frac{2n+1-\xi}{2\sqrt\tau}-\operatorname{erfc}
    \frac{2n+1+\xi}{2\sqrt\tau}` (tau = alpha t / L^2) = the eigen series
    :math:`\xi+\frac2\pi\sum_{n\ge1}\frac{(-1)^n}{n}\sin(n\pi\xi)e^{-n^2\pi^2\tau}` [1]_. For a
    piecewise-linear history with samples h_j (relative to T_S0) and slopes s_j,
    :math:`u(t_i)=h_0S(t_i)+\sum_j s_j[R(t_i-t_j)-R(t_i-t_{j+1})]`, R = int S, exactly; the
    sum is a convolution, done by FFT. The paper's Eq. 8 with R = 0 and beta_M -> inf keeps only
    the n = 0 term.

    References
    ----------
    .. [1] H. S. Carslaw, J. C. Jaeger, Conduction of Heat in Solids, 2nd ed., 1959, §3.4.

    Examples
    --------
    >>> from stimuli.properties import Skin
    >>> skin = Skin(1e-3)                      # receptors at 0.6 mm
    >>> t = np.arange(20001) * 1e-3            # 20 s at 1 kHz
    >>> T = skin_response(skin, t, np.full(t.size, 25.0), initial_temperature=35.0)
    >>> round(float(T[1000]), 3)               # 1 s after a 10 K step of the surface
    31.686
    >>> round(float(T[-1]), 3)                 # 20 s: steady, 35 - 0.6 * 10
    29.0
    >>> T, info = skin_response(skin, t, np.full(t.size, 25.0), tolerance=1e-3, full_output=True)
    >>> info.method
    'exact'
    """
    where = "skin_response"
    t, dt, h, T0 = _history(t, surface_temperature, initial_temperature, where)
    x = _check_depth(skin, depth, where)
    xi = x / skin.thickness
    layered = epidermis_properties is not None
    if tolerance is not None:
        try:
            tol = float(tolerance)
        except (TypeError, ValueError):
            tol = float("nan")
        if not (math.isfinite(tol) and tol > 0):
            raise ModelInputError(f"{where}: tolerance: expected a finite number > 0 in K, got {tolerance!r}")
    elif method not in METHODS:
        raise ModelInputError(f"{where}: method: expected one of {', '.join(METHODS)}, got {method!r}")
    if layered and tolerance is None and method != "numerical":
        raise ModelInputError(f"{where}: method: expected 'numerical' for layered skin "
                              f"(epidermis_properties), got {method!r}")

    if x <= 0.0 or x >= skin.thickness:
        u = np.zeros_like(h) if x <= 0.0 else h.copy()
        info = ResponseInfo(method if tolerance is None else "exact", 0.0)
    elif tolerance is not None:
        if layered:
            c = int(cells)
            while True:
                u, est = _numerical(skin, t, h, x, c, epidermis_properties, T0)
                if est <= tol:
                    break
                if c >= 256:
                    raise ModelInputError(f"{where}: tolerance: expected a tolerance the finite-volume "
                                          f"solver meets with <= 4 x 256 cells (estimate {est:.3g} K), "
                                          f"got {tolerance!r}")
                c *= 2
            info = ResponseInfo("numerical", est, c)
        else:
            # the paper's form is never cheaper here (same FFT convolution, a kernel of the same
            # cost, see ``thermocue bench model``), so the cheapest adequate method is "exact"
            u, bound = _exact(skin, t, dt, h, xi)
            if bound > tol:
                raise ModelInputError(f"{where}: tolerance: expected >= {bound:.3g} K (the exact "
                                      f"method's rounding bound), got {tolerance!r}")
            info = ResponseInfo("exact", bound)
    elif method == "exact":
        u, bound = _exact(skin, t, dt, h, xi)
        info = ResponseInfo("exact", bound)
    elif method == "paper":
        u, bound = _paper(skin, t, dt, h, xi)
        info = ResponseInfo("paper", bound)
    elif method == "paper-as-printed":
        u, bound = _printed(skin, t, dt, h, xi)
        info = ResponseInfo("paper-as-printed", bound)
    else:
        c = int(cells)
        u, est = _numerical(skin, t, h, x, c, epidermis_properties, T0)
        info = ResponseInfo("numerical", est, c)
    T = T0 + u
    return (T, info) if full_output else T

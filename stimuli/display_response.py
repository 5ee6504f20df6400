r"""The receptor response to a display-imposed surface temperature (docs/design.md ``skin_response``).

On a simulated trial the display imposes a temperature history g(t) on the skin surface x = L;
the skin 0 < x < L starts uniform at T_S0 and stays at T_S0 at x = 0. In the Laplace domain
(docs/design.md) :math:`\hat\theta_S = 1/s + (G(s) - 1/s)\,\sinh(q_S x)/\sinh(q_S L)`; in the time
domain the response at depth x is Duhamel's superposition of the slab's exact unit-step
response S(x, t) over the piecewise-linear history (:mod:`stimuli._slab_series`,
:mod:`stimuli._duhamel`).

A real finger touches the display's pad through its own contact resistance R (``resistance=``):
the boundary condition is then Robin, :math:`-\lambda_S\,\partial T/\partial x = (T_S(L^-) -
g)/R` at x = L, and the unit-step response at x is the inverse of
:math:`\sinh(q x)/(s\,[\sinh(qL) + R\beta_S\sqrt s\cosh(qL)])` (q = sqrt(s / alpha_S)),
inverted on the hyperbolic Bromwich contour of :mod:`stimuli.exact` and superposed the same way.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _slab_series as series
from ._duhamel import superpose
from .exact import INVERSION_ERROR, InversionPlan
from .errors import ModelInputError
from .finite_volume import (DEFAULT_CELLS, check_depth, check_resistance, uniform_times,
                            solve_surface)

__all__ = ["skin_response", "ResponseInfo", "METHODS", "ROBIN_METHODS"]

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
    t, dt = uniform_times(t, where)
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
    lo, hi = SURFACE_ABSURD_C
    if g.size and (float(np.min(g)) < lo or float(np.max(g)) > hi):
        raise ModelInputError(f"{where}: surface_temperature: expected a display surface within "
                              f"{lo:g}-{hi:g} °C (no thermal display touching skin goes beyond; the "
                              f"protocol's own safe range is checked by the session), got "
                              f"{float(np.min(g)):g}-{float(np.max(g)):g} °C")
    if not lo <= T0 <= hi:
        raise ModelInputError(f"{where}: initial_temperature: expected a skin temperature within "
                              f"{lo:g}-{hi:g} °C, got {initial_temperature!r}")
    return t, dt, g - T0, T0


#: Surface and skin temperatures skin_response refuses as absurd, °C (a display touching skin).
SURFACE_ABSURD_C = (-20.0, 80.0)


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


def _numerical(skin, t, h, x, cells, epidermis_properties, T0, resistance=0.0):
    """Finite volumes on the ``cells`` grid and its exact 2x and 4x bisections, extrapolated.

    The spatial error is c2 h^2 + c4 h^4 + ... on self-similar grids, so r1 = (4 u2 - u1)/3 and
    r2 = (4 u4 - u2)/3 are fourth-order and r2's error is about |r2 - r1| / 15; |r2 - r1| is
    returned as a conservative estimate.
    """
    u1, u2, u4 = (solve_surface(skin, t, h + T0, T0, x, cells=cells, split=k,
                                epidermis_properties=epidermis_properties,
                                resistance=resistance) - T0 for k in (1, 2, 4))
    r1 = (4.0 * u2 - u1) / 3.0
    r2 = (4.0 * u4 - u2) / 3.0
    return r2, float(np.max(np.abs(r2 - r1)))


def _refined(p, tolerance=None, where="skin_response"):
    """The ``"numerical"`` method: :func:`_numerical` on ``p.cells``, and with a ``tolerance``
    (K, already checked) the grid doubled (up to 256 cells) until the Richardson estimate is
    within it.

    The one refinement loop of the finite-volume solver (Dirichlet and Robin surfaces alike).
    """
    tol = None if tolerance is None else float(tolerance)
    c = int(p.cells)
    while True:
        u, est = _numerical(p.skin, p.t, p.h, p.x, c, p.epidermis_properties, p.T0,
                            resistance=p.resistance)
        if tol is None or est <= tol:
            return u, ResponseInfo("numerical", est, c)
        if c >= 256:
            raise ModelInputError(f"{where}: tolerance: expected a tolerance the finite-volume "
                                  f"solver meets with <= 4 x 256 cells (estimate {est:.3g} K), "
                                  f"got {tolerance!r}")
        c *= 2


@dataclass(frozen=True)
class _Problem:
    """One :func:`skin_response` call's checked inputs, what every method of :data:`METHODS` takes."""

    skin: object
    t: np.ndarray
    dt: float
    h: np.ndarray           # surface history relative to T0, K
    T0: float
    x: float
    cells: int
    epidermis_properties: object = None
    resistance: float = 0.0

    @property
    def xi(self):
        return self.x / self.skin.thickness


def _by_series(name, form):
    def method(p, tolerance=None, where="skin_response"):
        u, bound = form(p.skin, p.t, p.dt, p.h, p.xi)
        return u, ResponseInfo(name, bound)
    method.__name__ = method.__qualname__ = f"_{name.replace('-', '_')}_method"
    return method


def _robin_exact_method(p, tolerance=None, where="skin_response"):
    u, bound = _robin_exact(p.skin, p.t, p.dt, p.h, p.x, p.resistance)
    return u, ResponseInfo("exact", bound)


#: Methods accepted by :func:`skin_response`: name -> ``f(problem, tolerance, where)`` returning
#: ``(u, ResponseInfo)`` (the ``scipy.integrate`` ``METHODS = {'RK23': RK23, ...}`` shape), for
#: a surface imposed on the skin (R = 0) ...
METHODS = {"exact": _by_series("exact", _exact), "paper": _by_series("paper", _paper),
           "paper-as-printed": _by_series("paper-as-printed", _printed), "numerical": _refined}
#: ... and through a contact resistance R > 0 (the paper's forms assume R = 0).
ROBIN_METHODS = {"exact": _robin_exact_method, "numerical": _refined}


def _unknown_method(where, method):
    return ModelInputError(f"{where}: method: expected one of {', '.join(METHODS)}, got {method!r}")


def skin_response(skin, t, surface_temperature, initial_temperature=35.0, depth=None,
                  method="exact", tolerance=None, *, epidermis_properties=None,
                  cells=DEFAULT_CELLS, full_output=False, resistance=None):
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
    resistance : float or None, m^2 K/W, keyword-only
        Contact resistance R between the skin and the surface whose temperature is
        ``surface_temperature`` (e.g. the finger-pad resistance of a display); the boundary
        condition at x = L is then Robin, -lambda_S dT/dx = (T_S(L-) - g(t)) / R, and
        ``depth = L`` is the skin side L-. ``None`` or 0: g is imposed on the skin (Dirichlet).
        "paper" and "paper-as-printed" need R = 0.

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
        outside [0, L], an unknown method, a tolerance <= 0 or one no method can meet, a
        negative or non-finite resistance, "paper"/"paper-as-printed" with a resistance.

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

    *Contact resistance* (``resistance=R > 0``). A display drives the skin through the
    finger-pad contact, not directly: the pad at g(t) and the skin surface T_S(L-) differ by R
    times the heat flux. With :math:`\hat u = A\sinh(qx)` (u = T - T_S0, u(0) = 0) the Robin
    condition :math:`-\lambda_S q A\cosh(qL) = (A\sinh(qL) - \hat g)/R` and
    :math:`\lambda_S q = \beta_S\sqrt s` give
    :math:`\hat u(x) = \hat g\,\sinh(qx)/(\sinh(qL) + R\beta_S\sqrt s\cosh(qL))`, static
    gain x / (L + R lambda_S) (R in series with the skin's L / lambda_S). The step response S
    and the ramp remainder R(t) - gain t (transforms K/s and (K - gain)/s^2, K the kernel above,
    written with exp(-2 q .) factors so nothing overflows) are inverted on :mod:`stimuli.exact`'s
    hyperbolic contour (absolute error <= 1e-12 of each function's scale) and superposed by FFT
    as above: a 20 s, 1 kHz history takes about 3-9 ms here (two inversions at 20,000 times and
    one FFT convolution) and agrees with mpmath to ~3e-14 K (tests). The reported bound,
    1e-12 (|h_0| + 2 max|R_rest| TV(h) / dt) + rounding, is a worst case (1e-9..1e-7 K for
    typical profiles). ``"numerical"`` applies the same Robin condition in the finite-volume
    solver (R in series with the surface half-cell). R -> 0 recovers the Dirichlet case
    continuously (the difference is O(R)); for R >> L / lambda_S the response falls as 1 / R.

    Why: replaying the paper's Eq. 7 profile (the material-side interface temperature T_M(L+))
    on a pad that the finger touches through its own R_pad puts a second resistance in series,
    so the skin is warmed through R_pad from T_M(L+) instead of through nothing from T_S(L-):
    rough samples (R > R_pad) then feel colder on the display than in reality.
    :func:`stimuli.target_profile` ``side="compensated"`` gives the pad temperature that
    reproduces the real contact exactly.

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
    >>> T = skin_response(skin, t, np.full(t.size, 25.0), resistance=1e-3)   # through a pad's R
    >>> round(float(T[1000]), 3), round(float(T[-1]), 2)   # -> 35 - 10 * 0.6 / (1 + 0.34) = 30.52
    (33.649, 30.52)
    """
    where = "skin_response"
    t, dt, h, T0 = _history(t, surface_temperature, initial_temperature, where)
    x = check_depth(skin, depth, where)
    R = check_resistance(resistance, where)
    problem = _Problem(skin, t, dt, h, T0, x, cells, epidermis_properties, R)
    if R > 0.0:
        return _robin(problem, method, tolerance, full_output, where)
    layered = epidermis_properties is not None
    if tolerance is not None:
        tol = _check_tolerance(tolerance, where)
    elif method not in METHODS:
        raise _unknown_method(where, method)
    if layered and tolerance is None and method != "numerical":
        raise ModelInputError(f"{where}: method: expected 'numerical' for layered skin "
                              f"(epidermis_properties), got {method!r}")

    if x <= 0.0 or x >= skin.thickness:
        u = np.zeros_like(h) if x <= 0.0 else h.copy()
        info = ResponseInfo(method if tolerance is None else "exact", 0.0)
    elif tolerance is not None and layered:
        u, info = METHODS["numerical"](problem, tolerance, where)
    elif tolerance is not None:
        # the paper's form is never cheaper here (same FFT convolution, a kernel of the same
        # cost, see ``thermocue bench model``), so the cheapest adequate method is "exact"
        u, info = METHODS["exact"](problem)
        if info.error_bound > tol:
            raise ModelInputError(f"{where}: tolerance: expected >= {info.error_bound:.3g} K (the "
                                  f"exact method's rounding bound), got {tolerance!r}")
    else:
        u, info = METHODS[method](problem, None, where)
    T = T0 + u
    return (T, info) if full_output else T


def _check_tolerance(tolerance, where: str) -> float:
    """``tolerance`` (K) as a finite float > 0, or a ModelInputError naming it."""
    try:
        tol = float(tolerance)
    except (TypeError, ValueError):
        tol = float("nan")
    if not (math.isfinite(tol) and tol > 0):
        raise ModelInputError(f"{where}: tolerance: expected a finite number > 0 in K, got {tolerance!r}")
    return tol


def _robin(p, method, tolerance, full_output, where):
    """skin_response through a contact resistance R > 0 (Robin condition at x = L)."""
    layered = p.epidermis_properties is not None
    tol = None
    if tolerance is not None:
        tol = _check_tolerance(tolerance, where)
        method = "numerical" if layered else "exact"
    elif method not in METHODS:
        raise _unknown_method(where, method)
    if method not in ROBIN_METHODS:
        raise ModelInputError(f"{where}: method: expected {' or '.join(map(repr, ROBIN_METHODS))} with a "
                              f"contact resistance (the paper's forms assume R = 0), got {method!r}")
    if layered and method != "numerical":
        raise ModelInputError(f"{where}: method: expected 'numerical' for layered skin "
                              f"(epidermis_properties), got {method!r}")
    if p.x <= 0.0:
        u, info = np.zeros_like(p.h), ResponseInfo(method, 0.0)
    else:
        u, info = ROBIN_METHODS[method](p, tolerance, where)
        if method == "exact" and tol is not None and info.error_bound > tol:
            raise ModelInputError(f"{where}: tolerance: expected >= {info.error_bound:.3g} K (the "
                                  f"exact method's bound for this history), got {tolerance!r}")
    T = p.T0 + u
    return (T, info) if full_output else T


def _robin_kernels(skin, x, R, t):
    """Exact S(t) and R_rest(t) = int_0^t S - gain t of the skin behind a resistance R (see Notes).

    Returns ``(S, R_rest, gain, scale)`` with ``scale`` = max |R_rest| (s), for the error bound.
    """
    L, alpha, beta = skin.thickness, skin.diffusivity, skin.effusivity
    gain = x / (L + R * skin.conductivity)
    a = 1.0 / math.sqrt(alpha)

    def kernel(s):
        # sinh(q x) / (sinh(q L) + R beta p cosh(q L)) = [sinh(q x)/cosh(q L)] / (tanh(q L) + R beta p)
        # with every hyperbolic function through exp(-2 q .) <= 1 (Re q >= 0): no overflow
        p = np.sqrt(s)
        q = p * a
        eL = np.exp(-2.0 * q * L)
        ratio = np.exp(-q * (L - x)) * -np.expm1(-2.0 * q * x) / (1.0 + eL)
        tanh = -np.expm1(-2.0 * q * L) / (1.0 + eL)
        return ratio / (tanh + R * beta * p)

    S = np.zeros_like(t)
    Rr = np.zeros_like(t)
    pos = t > 0
    if np.any(pos):
        plan = InversionPlan(t[pos])          # both transforms share the nodes and kernel values
        k = kernel(plan.s)
        S[pos] = plan.apply(k / plan.s)
        Rr[pos] = plan.apply((k - gain) / (plan.s * plan.s))
    return S, Rr, gain, float(np.max(np.abs(Rr))) if Rr.size else 0.0


def _robin_exact(skin, t, dt, h, x, R):
    """Duhamel superposition of the exact Robin step response (Bromwich inversion), and its bound.

    The inversion's absolute error is below 1e-12 of a function's scale (:data:`INVERSION_ERROR`):
    |delta S| <= 1e-12 and |delta R_rest| <= 1e-12 max|R_rest|, so with the slopes s_j of the
    history |delta u| <= 1e-12 (|h_0| + 2 max|R_rest| sum |s_j|) = 1e-12 (|h_0| + 2 max|R_rest|
    TV(h) / dt), plus FFT rounding.
    """
    S, Rr, gain, scale = _robin_kernels(skin, x, R, t)
    u = superpose(h, dt, S, Rr, gain)
    tv = float(np.sum(np.abs(np.diff(h))))
    bound = INVERSION_ERROR * (abs(float(h[0])) + (2.0 * scale * tv / dt if dt > 0 else 0.0))
    bound += 4.0 * _EPS * float(np.max(np.abs(h))) * max(1.0, math.log2(max(h.size, 2)))
    return u, float(bound)

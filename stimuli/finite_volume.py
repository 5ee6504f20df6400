r"""Finite-volume model of the skin slab: layered skin, imposed surface history, or a contact.

The skin 0 < x < L is held at its initial temperature at x = 0 (the subdermal zone); the dermis
0..d and the epidermis d..L may have different properties; the thermoreceptors sit at x = d.
Two problems are solved:

* :func:`solve_surface` -- the display imposes a surface temperature g(t) at x = L
  (piecewise linear between samples on a uniform grid from t = 0, where it jumps from the
  initial temperature to g(0)), directly or through a contact resistance R (``resistance=``:
  Robin condition, R added in series with the surface half-cell);
* :func:`solve_contact` -- the skin touches a material (half-space, or a slab of thickness D
  with an insulated back) through a contact resistance R (the problem of
  :class:`stimuli.Contact`, here with layered skin allowed).

Method
------
Cell-centred finite volumes on a graded grid: cells are smallest at the surface (and, in the
material, at the interface) and grow linearly with the distance from it; the layer interface
d and the requested depth are always cell faces, so the temperature there is the
flux-continuous face value. Face conductances are harmonic (series resistances), the contact
resistance is added in series at x = L, a half-space is truncated 10 sqrt(alpha_M t_max)
deep. The semi-discrete system M dT/dt = -K T + b(t) is symmetric-definite and tridiagonal,
so it is diagonalised once (``scipy.linalg.eigh_tridiagonal`` on M^-1/2 K M^-1/2) and
advanced *exactly in time*: for the contact each mode decays as exp(-lambda_k t); for an
imposed piecewise-linear surface history the discrete step and ramp responses at the one
requested depth are superposed (Duhamel, FFT convolution). The only error is the spatial
one, second order in the cell size (halving every cell divides it by about 4). Nothing is
stored but the answer at the requested depth: no field history, no time stepping.

Cost: one tridiagonal eigen-decomposition (N ~ 50-250 cells) plus O(N_modes x N_t)
exponentials, where each mode is evaluated only while exp(-lambda_k t) > 1e-20.
"""
from __future__ import annotations

import math

import numpy as np

from ._duhamel import superpose
from ._fv_grid import (GROWTH, H_RATIO, DEFAULT_CELLS, Layer, check_cells, exp_sum, FVGrid,
                       face_weights, graded_faces, Modal, skin_grid, fv_skin_layers, split_cells)
from .errors import ModelInputError

__all__ = ["Layer", "solve_surface", "solve_contact", "DEFAULT_CELLS"]

# --------------------------------------------------------------------------- checks
def uniform_times(t, where):
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)):
        raise ModelInputError(f"{where}: t: expected a 1-D array of finite times in s, got shape "
                              f"{np.shape(t)!r}")
    if t[0] != 0.0:
        raise ModelInputError(f"{where}: t: expected uniform times starting at 0 s, got t[0] = {t[0]!r}")
    if t.size == 1:
        return t, 0.0
    dt = (t[-1] - t[0]) / (t.size - 1)
    if not dt > 0 or np.max(np.abs(np.diff(t) - dt)) > 1e-9 * max(dt, t[-1] * 1e-6):
        raise ModelInputError(f"{where}: t: expected uniformly spaced times (constant step), got "
                              f"steps from {np.min(np.diff(t))!r} to {np.max(np.diff(t))!r} s")
    return t, dt


def check_depth(skin, depth, where, *, allow_material=False, material_extent=None):
    d = skin.dermis if depth is None else depth
    try:
        d = float(d)
    except (TypeError, ValueError):
        raise ModelInputError(f"{where}: depth: expected a depth in m, got {depth!r}") from None
    hi = skin.thickness if not allow_material else skin.thickness + (material_extent or math.inf)
    if not (math.isfinite(d) and 0.0 <= d <= hi):
        raise ModelInputError(f"{where}: depth: expected 0 <= depth <= {hi!r} m (from the inner "
                              f"boundary), got {depth!r}")
    return d


def check_resistance(resistance, where):
    """R in m^2 K/W: None -> 0.0; finite and >= 0, else a ModelInputError naming the field."""
    if resistance is None:
        return 0.0
    try:
        R = float(resistance)
    except (TypeError, ValueError):
        R = float("nan")
    if not (math.isfinite(R) and R >= 0.0):
        raise ModelInputError(f"{where}: resistance: expected a finite number >= 0 in m^2 K/W, "
                              f"got {resistance!r}")
    return R


# --------------------------------------------------------------------------- surface problem
def _surface_kernel(skin, depth: float, *, cells: int = DEFAULT_CELLS,
                   epidermis_properties=None, split: int = 1, resistance: float = 0.0):
    """Discrete step response of the FV skin at ``depth`` to a unit surface step.

    Returns ``(gain, a, lam)``: S(t) = gain - sum_k (a_k / lam_k) exp(-lam_k t) and
    R(t) - gain t = -sum_k a_k / lam_k^2 (1 - exp(-lam_k t)). ``depth`` strictly inside (0, L),
    or ``depth == L`` with ``resistance > 0`` (the skin side L- of the contact, whose face value
    has a feed-through w g of the surface value; S then jumps to w at 0+, a discretisation
    artefact of order the surface cell's resistance over R that vanishes under refinement).
    ``split`` cuts every cell of the ``cells`` grid into that many equal cells (the exactly
    self-similar refinement used for Richardson extrapolation). ``resistance`` (m^2 K/W): the
    surface value is applied through it (Robin condition) instead of directly (Dirichlet).
    """
    cells = check_cells(cells)
    L = skin.thickness
    inner = [depth] if depth < L else []
    grid = skin_grid(skin, cells, inner, epidermis_properties, split=int(split))
    h = grid.h
    g_left = grid.k[0] / (0.5 * h[0])
    half_last = 0.5 * h[-1] / grid.k[-1]
    g_right = grid.k[-1] / (0.5 * h[-1]) if resistance == 0.0 else 1.0 / (half_last + resistance)
    op = Modal(grid, g_left, g_right)
    feed = 0.0
    if depth < L:
        c = face_weights(grid, op.half, depth)
    else:
        # face value at L-: (T_last / half + g / R) / (1 / half + 1 / R)
        feed = half_last / (half_last + resistance)
        c = np.zeros(grid.k.size)
        c[-1] = 1.0 - feed
    gamma = op.project(c)
    beta = op.V[-1, :] * g_right / op.sm[-1]
    a = gamma * beta
    gain = feed + float(np.sum(a / op.lam))
    return gain, a, op.lam


def solve_surface(skin, t, surface_temperature, initial_temperature=35.0, depth=None, *,
                  cells: int = DEFAULT_CELLS, epidermis_properties=None, split: int = 1,
                  resistance=None):
    """Temperature at one depth of the skin under an imposed surface temperature history.

    Parameters
    ----------
    skin : Skin
        Thickness L, dermis d and (dermis) properties.
    t : array_like, s
        Uniform times from 0.
    surface_temperature : array_like, °C
        g(t_i); linear in between; the surface jumps from ``initial_temperature`` to g(0) at t = 0.
    initial_temperature : float, °C
        Uniform skin temperature before t = 0, kept at x = 0.
    depth : float or None, m
        From the inner boundary; ``None`` is the receptor depth ``skin.dermis``.
    cells : int
        Grid resolution (about 1.3 x cells across the skin; every cell size scales as 1/cells).
    epidermis_properties : Layer or Material-like or None
        Properties of the epidermis (d < x < L); ``None``: the same as the dermis (``skin``).
    split : int
        Cut every cell into ``split`` equal cells (exactly self-similar refinement: the
        error falls by split^2; used for Richardson extrapolation).
    resistance : float or None, m^2 K/W
        Contact resistance R between the skin surface and the surface held at g(t) (Robin
        condition -lambda dT/dx = (T(L-) - g) / R at x = L); ``None`` or 0: g is imposed on
        the skin itself (Dirichlet). With R > 0, ``depth = L`` is the skin side L-.

    Returns
    -------
    ndarray, °C
        Temperature at ``depth`` at every t.

    Raises
    ------
    ModelInputError
        Non-uniform times, mismatched lengths, a depth outside [0, L], a bad ``cells`` or
        ``resistance``.

    Examples
    --------
    >>> from stimuli.properties import Skin
    >>> t = np.linspace(0.0, 20.0, 2001)
    >>> T = solve_surface(Skin(1e-3), t, np.full(t.size, 25.0), 35.0)
    >>> round(float(T[100]), 2)  # 1 s after a 10 K surface step (exact: 31.686)
    31.68
    >>> round(float(T[-1]), 2)   # 20 s: the steady state 35 - 0.6 * 10 (receptors at 0.6 L)
    29.0
    """
    where = "solve_surface"
    t, dt = uniform_times(t, where)
    g = np.asarray(surface_temperature, dtype=float)
    if g.shape != t.shape or not np.all(np.isfinite(g)):
        raise ModelInputError(f"{where}: surface_temperature: expected {t.size} finite values in °C "
                              f"(one per time), got shape {g.shape!r}")
    T0 = float(initial_temperature)
    x = check_depth(skin, depth, where)
    hist = g - T0
    R = check_resistance(resistance, where)
    if x <= 0.0:
        return np.full(t.shape, T0)
    if x >= skin.thickness and R == 0.0:
        return g.copy()
    if isinstance(split, bool) or not isinstance(split, (int, np.integer)) or split < 1:
        raise ModelInputError(f"{where}: split: expected an integer >= 1, got {split!r}")
    gain, a, lam = _surface_kernel(skin, x, cells=cells, epidermis_properties=epidermis_properties,
                                  split=split, resistance=R)
    S = gain - exp_sum(a / lam, lam, t)
    S[0] = 0.0
    R_rest = exp_sum(a / lam ** 2, lam, t) - float(np.sum(a / lam ** 2))
    u = superpose(hist, dt, S, R_rest, gain)
    return T0 + u


# --------------------------------------------------------------------------- contact problem
def _contact_grid(skin, material, t_max, cells, depths, epidermis_properties, split=1):
    L = skin.thickness
    derm, epi = fv_skin_layers(skin, epidermis_properties)
    h_min_s = L / (H_RATIO * cells)
    alpha_e = epi.conductivity / (epi.density * epi.specific_heat)
    skin_depths = [x for x in depths if 0.0 < x < L]
    sg = skin_grid(skin, cells, skin_depths, epidermis_properties, h_min=h_min_s)
    a_m = material.conductivity / (material.density * material.specific_heat)
    h_min_m = h_min_s * math.sqrt(a_m / alpha_e)
    if material.thickness is None:
        extent = 10.0 * math.sqrt(a_m * max(t_max, 1e-6))
        extent = max(extent, 20.0 * h_min_m)
    else:
        extent = material.thickness
    m_depths = [x - L for x in depths if x > L]
    s = graded_faces(extent, h_min_m, GROWTH / cells, m_depths)
    sf, mf = split_cells(sg.faces, split), split_cells(L + s, split)
    sf[-1] = mf[0] = L
    faces = np.concatenate([sf, mf[1:]])
    ns, nm = sf.size - 1, mf.size - 1
    k = np.concatenate([np.repeat(sg.k, split), np.full(nm, material.conductivity)])
    C = np.concatenate([np.repeat(sg.C, split), np.full(nm, material.density * material.specific_heat)])
    return FVGrid(faces, k, C, interface=ns), extent


def solve_contact(skin, material, resistance, skin_temperature, material_temperature, t,
                  depth=None, *, side: str = "skin", cells: int = DEFAULT_CELLS,
                  epidermis_properties=None, split: int = 1):
    """Temperature at one depth after the skin touches a material through a contact resistance.

    The numerical method behind ``Contact(..., method="numerical")``: the same problem as
    the exact Laplace solution (docs/design.md), plus optional layered skin.

    Parameters
    ----------
    skin : Skin
    material : Material
        ``thickness=None`` is a half-space (truncated 10 sqrt(alpha_M t_max) deep, where the
        temperature is held at ``material_temperature``); a slab has an insulated back.
    resistance : float, m^2 K/W
        Contact resistance R >= 0 between x = L- and x = L+.
    skin_temperature, material_temperature : float, °C
        T_S0 (uniform skin, kept at x = 0) and T_M0 (uniform material) before contact at t = 0.
    t : array_like, s
        Times >= 0, any order; t = 0 returns the initial temperature (at x = L: the side's
        one if R > 0, the t -> 0+ contact temperature of two half-spaces if R = 0).
    depth : float or None, m
        x from the inner skin boundary: 0..L in the skin, > L in the material (at most
        L + thickness for a slab); ``None`` is the receptor depth ``skin.dermis``.
    side : {"skin", "material"}
        At ``depth == L`` only: the skin side L- or the material side L+ of the interface.
    cells : int
        Grid resolution (every cell size scales as 1/cells).
    epidermis_properties : Layer or Material-like or None
        Epidermis properties; ``None``: homogeneous skin.
    split : int
        Cut every cell into ``split`` equal cells (self-similar refinement, for Richardson).

    Returns
    -------
    ndarray, °C
        Same shape as ``t``.

    Raises
    ------
    ModelInputError
        Negative or non-finite times, resistance or depth out of range, unknown side.

    Examples
    --------
    >>> from stimuli.properties import Skin, Material
    >>> steel = Material(14.9, 7900.0, 447.0)
    >>> T = solve_contact(Skin(1e-3), steel, 0.0, 35.0, 24.0, [1.0], depth=1e-3, side="material")
    >>> round(float(T[0]), 1)   # R = 0: near the contact temperature of two half-spaces, 25.52 °C
    25.5
    """
    where = "solve_contact"
    t_arr = np.asarray(t, dtype=float)
    shape = t_arr.shape
    t1 = t_arr.ravel()
    if t1.size == 0:
        return np.zeros(shape)
    if not np.all(np.isfinite(t1)) or np.any(t1 < 0):
        raise ModelInputError(f"{where}: t: expected finite times >= 0 s, got min {np.min(t1)!r}")
    try:
        R = float(resistance)
    except (TypeError, ValueError):
        R = float("nan")
    if not (math.isfinite(R) and R >= 0.0):
        raise ModelInputError(f"{where}: resistance: expected a finite R >= 0 in m^2 K/W, got {resistance!r}")
    if side not in ("skin", "material"):
        raise ModelInputError(f"{where}: side: expected 'skin' or 'material', got {side!r}")
    Ts0, Tm0 = float(skin_temperature), float(material_temperature)
    x = check_depth(skin, depth, where, allow_material=True, material_extent=material.thickness)
    cells = check_cells(cells)
    if isinstance(split, bool) or not isinstance(split, (int, np.integer)) or split < 1:
        raise ModelInputError(f"{where}: split: expected an integer >= 1, got {split!r}")
    if x <= 0.0:
        return np.full(shape, Ts0)
    theta = np.empty(t1.size)
    # One grid per window of times spanning at most _WINDOW_SPAN: a half-space truncated for
    # the latest time and graded for the earliest has a spectrum too wide for the eigen-solver
    # in double precision (foam, 50 µm skin, t from 1e-4 to 1e4 s: 0.18 in theta at 2.6e-4 s).
    hi = float(np.max(t1))
    todo = np.ones(t1.size, dtype=bool)
    while np.any(todo):
        now = todo & (t1 >= hi / _WINDOW_SPAN) if hi > 0.0 else todo
        theta[now] = _contact_theta(skin, material, R, t1[now], hi, x, side, cells,
                                    epidermis_properties, int(split))
        todo &= ~now
        if np.any(todo):
            hi = float(np.max(t1[todo]))
    return (Tm0 + (Ts0 - Tm0) * theta).reshape(shape)


#: Largest ratio of the latest to the earliest time solved on one grid by solve_contact.
_WINDOW_SPAN = 1e5


def _contact_theta(skin, material, R, t1, t_max, x, side, cells, epidermis_properties, split):
    """theta = (T - T_M0) / (T_S0 - T_M0) at depth ``x`` and times ``t1`` <= ``t_max``."""
    L = skin.thickness
    grid, extent = _contact_grid(skin, material, t_max, cells, [x], epidermis_properties, split)
    h = grid.h
    half = 0.5 * h / grid.k
    g_left = 1.0 / half[0]
    far_dirichlet = material.thickness is None
    g_right = 1.0 / half[-1] if far_dirichlet else 0.0
    op = Modal(grid, g_left, g_right, r_interface=R)
    n = grid.k.size
    i_m = grid.interface
    # theta = (T - T_M0) / (T_S0 - T_M0): 1 at x = 0, 0 at a truncated half-space's far end
    c = np.zeros(n)
    if x == L or (x > L and x >= L + extent):
        if x > L:                                  # far face of a slab (insulated): extrapolate
            c[-1] = 1.0
        else:
            G = op.G[i_m - 1]
            if side == "skin":
                w = G * half[i_m - 1]
                c[i_m - 1], c[i_m] = 1.0 - w, w
            else:
                w = G * half[i_m]
                c[i_m], c[i_m - 1] = 1.0 - w, w
    else:
        c = face_weights(grid, half, x)
    b = np.zeros(n)
    b[0] = g_left
    theta_inf = op.steady(b)
    theta0 = np.zeros(n)
    theta0[:i_m] = 1.0
    gamma = op.project(c)
    amp = op.V.T @ (op.sm * (theta0 - theta_inf))
    theta = float(c @ theta_inf) + exp_sum(gamma * amp, op.lam, t1)
    at0 = t1 == 0.0
    if np.any(at0):   # exactly at contact: the initial temperature of the side asked for
        theta[at0] = 1.0 if (x < L or (x == L and side == "skin")) else 0.0
        if x == L and R == 0.0:   # ... except the t -> 0+ contact value of two touching bodies
            epi = fv_skin_layers(skin, epidermis_properties)[1]
            bs = math.sqrt(epi.conductivity * epi.density * epi.specific_heat)
            bm = math.sqrt(material.conductivity * material.density * material.specific_heat)
            theta[at0] = bs / (bs + bm)
    return theta


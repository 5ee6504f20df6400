"""The finite-volume discretisation of :mod:`stimuli.finite_volume`: skin layers, the graded
grid, and its tridiagonal operator diagonalised once (modes and their exponential sums).

See :mod:`stimuli.finite_volume` (Method) for what is solved with it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh_tridiagonal, solve_banded

from .errors import ModelInputError

#: Default grid resolution (about 1.3 x this many cells across the skin).
DEFAULT_CELLS = 32
H_RATIO = 50.0      # smallest cell = L / (50 cells)
GROWTH = 4.0        # cell size grows by 4 / cells per unit distance from the surface
_DROP = 46.0         # a mode is dropped once exp(-lambda t) < e^-46 = 1e-20


@dataclass(frozen=True)
class Layer:
    """Thermal properties of one skin layer (SI).

    Parameters
    ----------
    conductivity : float, W/(m K)
    density : float, kg/m^3
    specific_heat : float, J/(kg K)
    """

    conductivity: float
    density: float
    specific_heat: float

    def __post_init__(self):
        for name in ("conductivity", "density", "specific_heat"):
            v = getattr(self, name)
            try:
                f = float(v)
            except (TypeError, ValueError):
                f = float("nan")
            if not (math.isfinite(f) and f > 0):
                raise ModelInputError(f"Layer: {name}: expected a finite number > 0, got {v!r}")
            object.__setattr__(self, name, f)

    @classmethod
    def of(cls, obj, where: str = "epidermis_properties") -> "Layer":
        """A Layer from anything with conductivity, density and specific_heat attributes."""
        if isinstance(obj, Layer):
            return obj
        try:
            return cls(obj.conductivity, obj.density, obj.specific_heat)
        except AttributeError:
            raise ModelInputError(f"{where}: expected an object with conductivity, density and "
                                  f"specific_heat, got {obj!r}") from None


# --------------------------------------------------------------------------- grid
def graded_faces(length: float, h_min: float, growth: float, breaks, *, h_max: float | None = None):
    """Faces on [0, length] measured from the fine end (s = 0), graded h(s) = h_min + growth s.

    Every value in ``breaks`` (distances from the fine end) becomes a face.
    """
    if h_max is None:
        h_max = math.inf

    def phi(s):  # cell count density integral, int ds / h(s)
        s = np.asarray(s, dtype=float)
        s_cap = (h_max - h_min) / growth if math.isfinite(h_max) else math.inf
        a = np.minimum(s, s_cap)
        out = np.log1p(growth * a / h_min) / growth
        if math.isfinite(s_cap):
            out = out + np.maximum(s - s_cap, 0.0) / h_max
        return out

    def phi_inv(p, s_lo, s_hi):
        # invert the monotone phi on [s_lo, s_hi] by dense interpolation then two Newton steps
        grid = np.linspace(s_lo, s_hi, 2049)
        s = np.interp(p, phi(grid), grid)
        for _ in range(2):
            h = np.minimum(h_min + growth * s, h_max)
            s = np.clip(s - (phi(s) - p) * h, s_lo, s_hi)
        return s

    pts = sorted({0.0, float(length), *[float(b) for b in breaks if 0.0 < b < length]})
    out = [0.0]
    for lo, hi in zip(pts[:-1], pts[1:]):
        n = max(1, int(math.ceil(float(phi(hi) - phi(lo)) - 1e-9)))
        p = np.linspace(float(phi(lo)), float(phi(hi)), n + 1)[1:-1]
        out.extend(phi_inv(p, lo, hi).tolist())
        out.append(hi)
    return np.asarray(out)


@dataclass
class FVGrid:
    faces: np.ndarray        # x of every face, ascending, m
    k: np.ndarray            # conductivity per cell
    C: np.ndarray            # rho c per cell
    interface: int | None = None   # index of the first material cell (contact), else None

    @property
    def h(self):
        return np.diff(self.faces)


def fv_skin_layers(skin, epidermis_properties):
    derm = Layer.of(skin, "skin")
    epi = derm if epidermis_properties is None else Layer.of(epidermis_properties)
    return derm, epi


def split_cells(faces, split):
    """Each cell cut into ``split`` equal cells (an exactly self-similar refinement)."""
    if split == 1:
        return faces
    f = np.asarray(faces)
    w = np.arange(split) / split
    inner = f[:-1, None] + np.diff(f)[:, None] * w[None, :]
    return np.concatenate([inner.ravel(), f[-1:]])


def skin_grid(skin, cells, depths, epidermis_properties, h_min=None, split=1):
    L, d = skin.thickness, skin.dermis
    derm, epi = fv_skin_layers(skin, epidermis_properties)
    h_min = L / (H_RATIO * cells) if h_min is None else h_min
    s_faces = graded_faces(L, h_min, GROWTH / cells, [L - d] + [L - x for x in depths])
    x = split_cells(np.sort(L - s_faces), split)
    x[0], x[-1] = 0.0, L
    centres = 0.5 * (x[:-1] + x[1:])
    in_epi = centres > d
    k = np.where(in_epi, epi.conductivity, derm.conductivity)
    C = np.where(in_epi, epi.density * epi.specific_heat, derm.density * derm.specific_heat)
    return FVGrid(x, k, C)


def check_cells(cells):
    if isinstance(cells, bool) or not isinstance(cells, (int, np.integer)) or cells < 2:
        raise ModelInputError(f"finite_volume: cells: expected an integer >= 2, got {cells!r}")
    return int(cells)


# --------------------------------------------------------------------------- operator
class Modal:
    """Tridiagonal operator of a grid, diagonalised: M dT/dt = -K T + boundary terms."""

    def __init__(self, grid: FVGrid, g_left: float, g_right: float, r_interface: float = 0.0):
        h = grid.h
        half = 0.5 * h / grid.k                       # half-cell resistances
        rs = half[:-1] + half[1:]
        if grid.interface is not None:
            rs[grid.interface - 1] += r_interface
        G = 1.0 / rs                                   # conductances between neighbours
        self.G, self.half = G, half
        m = grid.C * h
        diag = np.zeros_like(m)
        diag[:-1] += G
        diag[1:] += G
        diag[0] += g_left
        diag[-1] += g_right
        self.diag_K, self.m = diag, m
        sm = np.sqrt(m)
        self.lam, self.V = eigh_tridiagonal(diag / m, -G / (sm[:-1] * sm[1:]))
        self.sm = sm

    def steady(self, b):
        """K^-1 b (tridiagonal solve)."""
        ab = np.zeros((3, self.m.size))
        ab[0, 1:] = -self.G
        ab[1] = self.diag_K
        ab[2, :-1] = -self.G
        return solve_banded((1, 1), ab, b)

    def project(self, c):
        """Output weights per mode for the output c . T: gamma_k = (V^T M^-1/2 c)_k."""
        return self.V.T @ (c / self.sm)


def face_weights(grid: FVGrid, half, x: float):
    """Output vector c (c . T) for the temperature at interior face x (no resistance there)."""
    i = int(np.argmin(np.abs(grid.faces - x)))
    if not (0 < i < grid.faces.size - 1) or abs(grid.faces[i] - x) > 1e-12 * grid.faces[-1]:
        raise AssertionError("depth is not a face of the grid")  # pragma: no cover - grid invariant
    c = np.zeros(grid.k.size)
    ga, gb = 1.0 / half[i - 1], 1.0 / half[i]
    c[i - 1], c[i] = ga / (ga + gb), gb / (ga + gb)
    return c


def exp_sum(coef, lam, t):
    """sum_k coef_k exp(-lam_k t) for every t (t >= 0, any order), dropping decayed modes."""
    t = np.asarray(t, dtype=float)
    order = np.argsort(t, kind="stable")
    ts = t[order]
    out = np.zeros_like(ts)
    keep = coef != 0.0
    for a, l in zip(coef[keep], lam[keep]):
        stop = int(np.searchsorted(ts, _DROP / l, side="right"))
        if stop == 0:
            continue
        out[:stop] += a * np.exp(-l * ts[:stop])
    res = np.empty_like(out)
    res[order] = out
    return res

"""A 2-D axisymmetric check of the lateral-spreading stand-in (``Scene.effective_thickness_m``).

The paper's samples are 20 x 23 mm plates, 3 mm thick, touched over A = 135 mm^2. Here the plate is
a disc of equal area (radius b = sqrt(20 * 23 mm^2 / pi) = 12.1 mm), insulated everywhere except
the contact disc r < a = sqrt(A / pi) = 6.56 mm on top, where every ring of the plate is coupled
through R to its own 1-D skin column (the skin's lateral conduction is neglected: k_S/k_M = 0.02).
Finite volumes in (r, z) and in each skin column, integrated by scipy's BDF with the sparse
Jacobian; theta = (T - T_M0) / (T_S0 - T_M0) as in :mod:`stimuli`.

:func:`lateral_check` compares the contact-averaged material-side interface temperature and the
receptor temperature of this 2-D model with the 1-D models of :mod:`stimuli.scene`: the insulated
3 mm slab, the half-space and the slab of :func:`stimuli.scene.lateral_effective_thickness` at
the end time. ``a = b`` (contact over the whole plate) reduces the 2-D problem to the 1-D
insulated slab, which checks the 2-D code against the exact solution (tests).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["axisymmetric_contact", "lateral_check"]


def axisymmetric_contact(skin, steel, R, t_eval, *, plate_radius=12.1e-3, contact_radius=6.56e-3,
                         thickness=3e-3, dr=0.25e-3, nz=24, nx=26):
    """Contact-averaged theta at the material side of the interface and at the receptors.

    Returns
    -------
    (theta_interface, theta_receptor) : ndarrays over ``t_eval``
    """
    import scipy.sparse as sp
    from scipy.integrate import solve_ivp

    b, a, D = plate_radius, contact_radius, thickness
    n_c = max(1, int(round(a / dr)))
    a = n_c * dr
    nr = n_c + max(0, int(round((b - a) / dr)))
    rf = np.arange(nr + 1) * dr
    if plate_radius <= a + 1e-12:
        nr, rf = n_c, np.arange(n_c + 1) * dr
    area = 0.5 * (rf[1:] ** 2 - rf[:-1] ** 2)              # per radian
    dz = D / nz
    km, rcm = steel.conductivity, steel.density * steel.specific_heat
    L = skin.thickness
    dx = L / nx
    ks, rcs = skin.conductivity, skin.density * skin.specific_heat
    n_m = nr * nz
    n_s = n_c * nx

    def im(i, j):            # plate cell: ring i, layer j (j = 0 at the contact face)
        return i * nz + j

    def is_(i, k):           # skin cell: ring i, k = 0 at the core, nx - 1 at the surface
        return n_m + i * nx + k

    n = n_m + n_s
    rows, cols, vals = [], [], []
    cap = np.empty(n)
    rhs = np.zeros(n)

    def couple(p, q, g):
        rows.extend([p, q, p, q]); cols.extend([p, q, q, p]); vals.extend([-g, -g, g, g])

    for i in range(nr):
        for j in range(nz):
            p = im(i, j)
            cap[p] = rcm * area[i] * dz
            if j + 1 < nz:
                couple(p, im(i, j + 1), km * area[i] / dz)
            if i + 1 < nr:
                rc_i, rc_o = 0.5 * (rf[i] + rf[i + 1]), 0.5 * (rf[i + 1] + rf[i + 2])
                couple(p, im(i + 1, j), km * rf[i + 1] * dz / (rc_o - rc_i))
    for i in range(n_c):
        for k in range(nx):
            p = is_(i, k)
            cap[p] = rcs * area[i] * dx
            if k + 1 < nx:
                couple(p, is_(i, k + 1), ks * area[i] / dx)
        g_core = ks * area[i] / (0.5 * dx)                 # core held at theta = 1
        rows.append(is_(i, 0)); cols.append(is_(i, 0)); vals.append(-g_core)
        rhs[is_(i, 0)] += g_core
        g_c = area[i] / (0.5 * dx / ks + R + 0.5 * dz / km)
        couple(is_(i, nx - 1), im(i, 0), g_c)
    A = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
    A = sp.diags(1.0 / cap) @ A
    f = rhs / cap
    y0 = np.zeros(n)
    y0[n_m:] = 1.0
    sol = solve_ivp(lambda t, y: A @ y + f, (0.0, float(max(t_eval))), y0, method="BDF",
                    t_eval=np.asarray(t_eval, dtype=float), jac=A, rtol=1e-8, atol=1e-10)
    Y = sol.y
    w = area[:n_c] / area[:n_c].sum()
    # material side of the interface: the top plate cell minus half a cell's drop of the flux
    top = np.array([Y[im(i, 0)] for i in range(n_c)])
    surf = np.array([Y[is_(i, nx - 1)] for i in range(n_c)])
    g_sm = 1.0 / (0.5 * dx / ks + R + 0.5 * dz / km)
    flux = g_sm * (surf - top)                              # per area, theta units
    interface = w @ (top + flux * 0.5 * dz / km)
    # receptors at x = skin.dermis from the core: linear interpolation between cell centres
    xc = (np.arange(nx) + 0.5) * dx
    k0 = int(np.clip(np.searchsorted(xc, skin.dermis) - 1, 0, nx - 2))
    s = (skin.dermis - xc[k0]) / dx
    rec = np.array([(1 - s) * Y[is_(i, k0)] + s * Y[is_(i, k0 + 1)] for i in range(n_c)])
    return interface, w @ rec


def lateral_check(times=(1.0, 3.0, 8.0, 20.0), roughness_m=12.5e-6, skin_thickness_m=650e-6, **grid):
    """Rows comparing the 2-D plate with the 1-D options (°C, 35.5 °C skin on 20 °C steel)."""
    from stimuli import Skin, contact_resistance, material
    from stimuli.layered import LayeredContact, skin_layers
    from stimuli.scene import lateral_effective_thickness

    skin = Skin(skin_thickness_m)
    steel = material("stainless_steel")
    R = float(contact_resistance(roughness_m, skin=skin, material=steel))
    t = np.asarray(times, dtype=float)
    dT, T0 = 15.5, 20.0
    th_i, th_r = axisymmetric_contact(skin, steel, R, t, **grid)
    rows = {"2-D plate 20x23x3 mm (axisymmetric)": (T0 + dT * th_i, T0 + dT * th_r)}
    d_eff = lateral_effective_thickness(3e-3, steel.diffusivity, float(t[-1]))
    for label, D in (("1-D insulated 3 mm slab", 3e-3), ("1-D half-space", None),
                     (f"1-D slab, effective {d_eff * 1e3:.1f} mm", d_eff)):
        c = LayeredContact(skin_layers(skin, layered=False), steel.with_thickness(D), R, 35.5, 20.0)
        rows[label] = (c.temperature("interface_material", t), c.temperature("receptor", t, skin.dermis))
    return t, rows


if __name__ == "__main__":   # pragma: no cover
    t, rows = lateral_check()
    print("| model | " + " | ".join(f"interface @{v:g}s" for v in t) + " | "
          + " | ".join(f"receptor @{v:g}s" for v in t) + " |")
    print("|---" * (2 * t.size + 1) + "|")
    for k, (a, b) in rows.items():
        print(f"| {k} | " + " | ".join(f"{v:.2f}" for v in a) + " | " + " | ".join(f"{v:.2f}" for v in b) + " |")

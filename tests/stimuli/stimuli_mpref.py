"""Independent high-precision references (mpmath), shared by the stimuli tests.

The Laplace-domain solution of docs/design.md is written here again, in mpmath, with
plain hyperbolic functions (no rewriting), and inverted with mpmath's own Talbot
method at 30 significant digits.
"""
import mpmath as mp

DPS = 30


def theta_reference(skin, material, R, x, t, kind):
    """theta_S(x, t) (kind "skin") or theta_M(x, t) (kind "material") to ~20 digits."""
    with mp.workdps(DPS):
        L = mp.mpf(skin.thickness)
        a_s, b_s = mp.mpf(skin.diffusivity), mp.mpf(skin.effusivity)
        a_m, b_m = mp.mpf(material.diffusivity), mp.mpf(material.effusivity)
        D = None if material.thickness is None else mp.mpf(material.thickness)
        R, x = mp.mpf(R), mp.mpf(x)

        def fhat(s):
            p = mp.sqrt(s)
            qs, qm = p / mp.sqrt(a_s), p / mp.sqrt(a_m)
            zm = 1 / (b_m * p) if D is None else mp.coth(qm * D) / (b_m * p)
            flux = 1 / (s * (R + mp.tanh(qs * L) / (b_s * p) + zm))
            if kind == "skin":
                return 1 / s - flux * mp.sinh(qs * x) / (b_s * p * mp.cosh(qs * L))
            if D is None:
                return flux * mp.exp(-qm * (x - L)) / (b_m * p)
            return flux * mp.cosh(qm * (L + D - x)) / (b_m * p * mp.sinh(qm * D))

        return float(mp.invertlaplace(fhat, mp.mpf(t), method="talbot"))


def theta_interface_r0_series(skin, material, t):
    """theta_M(L+, t) for R = 0, half-space: the method-of-images series, in mpmath.

    theta = b/(1+b)... written from the image solution:
    theta = beta_S/(beta_S+beta_M) * [1 + (1 - g) sum_{n>=1} (-g)^(n-1) erfc(n L / sqrt(alpha_S t))],
    g = (beta_S - beta_M)/(beta_S + beta_M).
    """
    with mp.workdps(DPS):
        bs, bm = mp.mpf(skin.effusivity), mp.mpf(material.effusivity)
        g = (bs - bm) / (bs + bm)
        z = mp.mpf(skin.thickness) / mp.sqrt(mp.mpf(skin.diffusivity) * t)
        tail = mp.nsum(lambda n: (-g) ** (n - 1) * mp.erfc(n * z), [1, mp.inf])
        return float(bs / (bs + bm) * (1 + (1 - g) * tail))


def theta_layered_reference(layers, material, R, x, t, kind, support=None, dps=DPS):
    """theta of a layered, perfused skin (kind "skin" at depth x, or "material" at x >= L).

    Written independently of :mod:`stimuli.layered`: each layer is the 2 x 2 transfer matrix
    [[cosh qh, z sinh qh], [sinh qh / z, cosh qh]] acting on (deficit, flux), started from the
    core (deficit 0) -- plain mpmath hyperbolic functions, no impedance recursion -- and the
    transform is inverted with mpmath's Talbot method.
    ``layers``: (thickness, conductivity, density, specific_heat, perfusion, blood_rho_c) tuples,
    core to surface; ``material``: (conductivity, density, specific_heat, thickness or None);
    ``support``: (conductivity, density, specific_heat) or None.
    """
    with mp.workdps(dps):
        lay = [tuple(mp.mpf(v) for v in row) for row in layers]
        km, rm, cm, D = material
        km, rm, cm = mp.mpf(km), mp.mpf(rm), mp.mpf(cm)
        D = None if D is None else mp.mpf(D)
        R, x = mp.mpf(R), mp.mpf(x)
        Ltot = sum(row[0] for row in lay)

        def layer_matrix(q, z, h):
            return mp.matrix([[mp.cosh(q * h), z * mp.sinh(q * h)], [mp.sinh(q * h) / z, mp.cosh(q * h)]])

        def skin_matrix(s, upto):
            M = mp.eye(2)
            bottom = mp.mpf(0)
            for h, k, rho, c, w, rbcb in lay:
                q = mp.sqrt((s + w * rbcb / (rho * c)) * rho * c / k)
                z = 1 / (k * q)
                hh = min(h, upto - bottom)
                if hh > 0:
                    M = layer_matrix(q, z, hh) * M
                bottom += h
            return M

        def material_state(s):
            """(deficit-free) material: returns a function eta -> theta per unit interface flux."""
            qm = mp.sqrt(s * rm * cm / km)
            zm = 1 / (km * qm)
            if D is None:
                return lambda eta: zm * mp.exp(-qm * eta)
            if support is None:
                vb = mp.matrix([[1], [0]])          # (theta, flux) at the insulated back
            else:
                kb, rb, cb = (mp.mpf(v) for v in support)
                qb = mp.sqrt(s * rb * cb / kb)
                vb = mp.matrix([[1 / (kb * qb)], [1]])
            # going up from the back: theta(D - y), flux toward the back
            top = layer_matrix(qm, zm, D) * vb
            return lambda eta: (layer_matrix(qm, zm, D - eta) * vb)[0] / top[1]

        def fhat(s):
            M = skin_matrix(s, Ltot)
            Zs = M[0, 1] / M[1, 1]
            mat = material_state(s)
            F = 1 / (s * (R + Zs + mat(mp.mpf(0))))
            if kind == "skin":
                Mx = skin_matrix(s, x)
                return 1 / s - F * Mx[0, 1] / M[1, 1]
            return F * mat(x - Ltot)

        return float(mp.invertlaplace(fhat, mp.mpf(t), method="talbot"))

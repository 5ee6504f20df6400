"""Independent high-precision references (mpmath), shared by the stimuli tests.

The Laplace-domain solution of DESIGN.md is written here again, in mpmath, with
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

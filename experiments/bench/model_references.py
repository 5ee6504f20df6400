"""The references ``thermocue bench model`` measures every method against (mpmath, bench only).

Independent of :mod:`stimuli`'s solvers: the exact interface temperature by mpmath's Talbot
inversion of the Laplace-domain solution (40 digits), the receptor's response by a Duhamel sum
with its own image/eigen series (30 digits; the Robin slab's for the pad), and the layered,
perfused skin by 2 x 2 transfer matrices; :func:`reference_times` are the samples they are
evaluated at. :mod:`.model` uses them.
"""
from __future__ import annotations

import numpy as np

__all__ = ["DURATION_S", "RATE_HZ", "reference_times", "interface_reference",
           "receptor_reference", "receptor_robin_reference", "layered_reference"]

DURATION_S = 20.0
RATE_HZ = 1000.0


def reference_times():
    geo = np.unique(np.round(np.geomspace(1e-3, DURATION_S, 30) * RATE_HZ).astype(int))
    uni = np.round(np.linspace(0.5, DURATION_S, 12) * RATE_HZ).astype(int)
    return np.unique(np.concatenate([geo, uni]))          # sample indices


def interface_reference(skin, steel, R, idx, dps=40):
    """theta_M(L+, t) by mpmath Talbot inversion of the transform in docs/design.md (independent of stimuli)."""
    import mpmath as mp
    with mp.workdps(dps):
        a_s = mp.mpf(skin.conductivity) / (mp.mpf(skin.density) * mp.mpf(skin.specific_heat))
        b_s = mp.sqrt(mp.mpf(skin.conductivity) * mp.mpf(skin.density) * mp.mpf(skin.specific_heat))
        b_m = mp.sqrt(mp.mpf(steel.conductivity) * mp.mpf(steel.density) * mp.mpf(steel.specific_heat))
        L, Rm = mp.mpf(skin.thickness), mp.mpf(R)

        def fhat(s):
            p = mp.sqrt(s)
            F = (1 / s) / (Rm + mp.tanh(p / mp.sqrt(a_s) * L) / (b_s * p) + 1 / (b_m * p))
            return F / (b_m * p)

        return np.array([float(mp.invertlaplace(fhat, mp.mpf(int(i)) / int(RATE_HZ), method="talbot"))
                         for i in idx])


def receptor_reference(skin, h, idx, dps=30):
    """Exact receptor response (relative to T_S0) of the piecewise-linear history h, in mpmath.

    u_i = h_0 S(t_i) + sum_j s_j [R(t_i - t_j) - R(t_i - t_{j+1})], with the slab's step response S
    and its integral R from the image series (tau < 1/4) or the eigen series, each summed in
    mpmath until the terms fall below 1e-40.
    """
    import mpmath as mp
    with mp.workdps(dps):
        L = mp.mpf(skin.thickness)
        a = mp.mpf(skin.conductivity) / (mp.mpf(skin.density) * mp.mpf(skin.specific_heat))
        xi = mp.mpf(skin.dermis) / L
        Td = L * L / a
        dt = mp.mpf(1) / int(RATE_HZ)
        tiny = mp.mpf(10) ** -40

        def i2erfc4(z):            # 4 i^2 erfc(z)
            return (1 + 2 * z * z) * mp.erfc(z) - 2 * z * mp.exp(-z * z) / mp.sqrt(mp.pi)

        def S_R(m):
            if m == 0:
                return mp.mpf(0), mp.mpf(0)
            tau = a * m * dt / (L * L)
            S = R = mp.mpf(0)
            if tau < mp.mpf(1) / 4:
                n = 0
                while True:
                    za = (2 * n + 1 - xi) / (2 * mp.sqrt(tau))
                    zb = (2 * n + 1 + xi) / (2 * mp.sqrt(tau))
                    dS = mp.erfc(za) - mp.erfc(zb)
                    S += dS
                    R += Td * tau * (i2erfc4(za) - i2erfc4(zb))
                    if abs(dS) < tiny and n > 0:
                        break
                    n += 1
            else:
                S, R = xi, xi * m * dt - Td * (xi - xi ** 3) / 6
                n = 1
                while True:
                    e = mp.exp(-(n * mp.pi) ** 2 * tau)
                    sgn = (-1) ** n * mp.sin(n * mp.pi * xi)
                    S += 2 / mp.pi * sgn / n * e
                    R -= Td * 2 / mp.pi ** 3 * sgn / n ** 3 * e
                    if e < tiny:
                        break
                    n += 1
            return S, R

        return _duhamel_mp(S_R, h, idx, dt)


def receptor_robin_reference(skin, R, h, idx, dps=30):
    """Receptor response (relative to T_S0) through a finger-pad resistance R, in mpmath.

    The Duhamel sum of :func:`receptor_reference` with the Robin slab's step response S and its
    integral, from the eigenfunction series (independent of stimuli's Laplace inversion): with
    u(0) = 0 and lambda u_x(L) = (h - u(L)) / R, the modes are sin(mu_n x / L) with
    sin mu + b mu cos mu = 0, b = lambda R / L, mu_n in ((n - 1/2) pi, n pi);
    S = x/G + sum c_n sin(mu_n xi) e^(-mu_n^2 tau), G = L + R lambda,
    c_n = -L^2 (sin mu - mu cos mu) / (mu^2 G N_n), N_n = L/2 (1 - sin 2mu / (2 mu));
    int_0^t S = x t/G + phi(x) - sum c_n sin(mu_n xi) L^2/(alpha mu_n^2) e^(-mu_n^2 tau), where
    phi = x^3/(6 alpha G) - x L^2 (3 lambda R + L)/(6 alpha G^2) is the ramp's quasi-static part.
    Terms are summed until e^(-mu_n^2 tau) < 1e-40.
    """
    import mpmath as mp
    with mp.workdps(dps):
        L = mp.mpf(skin.thickness)
        lam = mp.mpf(skin.conductivity)
        a = lam / (mp.mpf(skin.density) * mp.mpf(skin.specific_heat))
        Rm = mp.mpf(R)
        x = mp.mpf(skin.dermis)
        xi = x / L
        G = L + Rm * lam
        b = lam * Rm / L
        dt = mp.mpf(1) / int(RATE_HZ)
        tiny = mp.mpf(10) ** -40
        phi = x ** 3 / (6 * a * G) - x * L * L * (3 * lam * Rm + L) / (6 * a * G * G)
        tau1 = a * dt / (L * L)
        modes = []              # (mu^2, c_n sin(mu xi), same * L^2 / (alpha mu^2))
        n = 1
        while True:
            mu = mp.findroot(lambda m: mp.sin(m) + b * m * mp.cos(m),
                             ((n - mp.mpf(1) / 2) * mp.pi, n * mp.pi), solver="anderson")
            N = L / 2 * (1 - mp.sin(2 * mu) / (2 * mu))
            cs = -L * L * (mp.sin(mu) - mu * mp.cos(mu)) / (mu * mu * G * N) * mp.sin(mu * xi)
            modes.append((mu * mu, cs, cs * L * L / (a * mu * mu)))
            if mp.exp(-mu * mu * tau1) < tiny:
                break
            n += 1

        def S_R(m):
            if m == 0:
                return mp.mpf(0), mp.mpf(0)
            tau = tau1 * m
            S, Ri = x / G, x * m * dt / G + phi
            for mu2, cs, cr in modes:
                e = mp.exp(-mu2 * tau)
                S += cs * e
                Ri -= cr * e
                if e < tiny:
                    break
            return S, Ri

        return _duhamel_mp(S_R, h, idx, dt)


def _duhamel_mp(S_R, h, idx, dt):
    """u_i = h_0 S(t_i) + sum_j s_j [R(t_i - t_j) - R(t_i - t_{j+1})] in mpmath (inside workdps)."""
    import mpmath as mp
    top = int(max(idx))
    SR = [S_R(m) for m in range(top + 1)]
    D = [SR[m][1] - SR[m - 1][1] for m in range(1, top + 1)]      # D_m, m = 1..top
    hm = [mp.mpf(float(v)) for v in h[: top + 1]]
    slopes = [(hm[j + 1] - hm[j]) / dt for j in range(top)]
    out = []
    for i in idx:
        i = int(i)
        u = hm[0] * SR[i][0] + mp.fsum(slopes[j] * D[i - j - 1] for j in range(i))
        out.append(float(u))
    return np.array(out)


# --------------------------------------------------------------------------- bench-only method
def layered_reference(layers, steel, R, idx, dps=30):
    """theta_S at the receptor (the dermis-epidermis boundary) of a layered, perfused skin on a
    steel half-space: 2 x 2 transfer matrices in mpmath (plain cosh/sinh, from the core up; not
    stimuli.layered's impedance recursion) inverted by mpmath's Talbot method."""
    import mpmath as mp
    from stimuli.layered import BLOOD_HEAT_CAPACITY
    with mp.workdps(dps):
        rows = [(mp.mpf(l.thickness), mp.mpf(l.conductivity), mp.mpf(l.density) * mp.mpf(l.specific_heat),
                 mp.mpf(l.perfusion) * mp.mpf(BLOOD_HEAT_CAPACITY)) for l in layers]
        b_m = mp.sqrt(mp.mpf(steel.conductivity) * mp.mpf(steel.density) * mp.mpf(steel.specific_heat))
        Rm = mp.mpf(R)

        def stack(s, n):
            M = mp.eye(2)
            for h, k, rc, wb in rows[:n]:
                q = mp.sqrt((s * rc + wb) / k)
                z = 1 / (k * q)
                M = mp.matrix([[mp.cosh(q * h), z * mp.sinh(q * h)],
                               [mp.sinh(q * h) / z, mp.cosh(q * h)]]) * M
            return M

        def fhat(s):
            M = stack(s, len(rows))
            F = 1 / (s * (Rm + M[0, 1] / M[1, 1] + 1 / (b_m * mp.sqrt(s))))
            return 1 / s - F * stack(s, len(rows) - 1)[0, 1] / M[1, 1]

        return np.array([float(mp.invertlaplace(fhat, mp.mpf(int(i)) / int(RATE_HZ), method="talbot"))
                         for i in idx])

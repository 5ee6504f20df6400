r"""The paper's closed forms: as printed, and corrected.

Notation of [1]_: mu = sqrt(alpha_S / alpha_M), beta = beta_S / beta_M,
gamma = (beta - 1) / (beta + 1), H_1 = (beta + 1) / (R lambda_S), and
a = sqrt(alpha_S t). Every ``exp(H_1 z + H_1^2 alpha_S t) erfc(H_1 a + z / 2a)``
is evaluated as ``erfcx(H_1 a + z / 2a) exp(-(z / 2a)^2)``
(:func:`stimuli._special.exp_erfc`), finite for R -> 0 (H_1 -> inf) where the
printed product is ``inf * 0``. Infinite sums are summed until the remaining
terms are below 1e-17 (bounded by |gamma|^n and by erfc(nL / a)); a sum whose
summand does not depend on n (the printed e_SR, e_MR) is summed exactly as a
geometric series.

The printed errors, each found by comparison with the exact solution
(:mod:`stimuli.exact`) and shown by a test in ``tests/stimuli/test_paper_forms.py``:

1. **Eq. 3b, first erfc: sign of mu(x - L).** Printed ``2nL - mu(x - L)``; the
   image solution of the R = 0 problem gives ``2nL + mu(x - L)``. With the
   printed sign the material would warm *more* with depth, and the n = 0 term
   no longer tends to the two-half-space solution (1 + gamma)/2 erfc(mu(x-L)/2a)
   as L -> inf. At R = 0 (steel, L = 650 um) the printed form, summed to
   convergence, exceeds the exact theta by 0.075 at x - L = 1 mm, t = 1 s (0.20
   at t = 0.1 s); the corrected form agrees with the exact one to 4e-15.
   (At x = L+ the sign does not matter, so Eq. 7 is unaffected.)
2. **Eq. 4b, second erfc: (2n + 1) L.** Must be (2n + 2) L as in Eq. 3b (and
   as Eq. 7, "derived from 4b", itself prints for n = 0: 2L). At R = 0, x = L+
   the printed 4b exceeds the exact theta by 0.016 at t = 1 s and 0.051 at
   t = 20 s (steel, L = 650 um); the printed 3b there is exact to 4e-15.
3. **e_SR and e_MR lack n.** Each image term n carries its own resistance term
   with the same shifted distance as its erfc: c_n = (2n+1)L - x, d_n =
   (2n+1)L + x (skin), a_n = 2nL + mu(x-L), b_n = (2n+2)L + mu(x-L) (material).
   Evidence (t -> 0+ limit): with R > 0 the exact interface temperature starts
   from the material's initial temperature, theta_M(L+, 0+) = 0, and so does the
   corrected series; the printed series summed to convergence starts at
   gamma / 2 (-0.36 for steel: colder than the material itself). On the skin
   side, theta_S(L-, 0+) = 1 (the skin has not yet lost heat): exact and
   corrected Eq. 3a give 0.99985 at t = 1e-8 s (steel, L = 650 um,
   R = 6.5e-4 m^2 K/W), the printed e_SR summed over n gives 3.245, a skin
   three times warmer than it started.
4. **e_MR: sign between its two terms.** Each erfc(z / 2a) - E(z) is the
   inverse transform of e^{-z p / sqrt(alpha_S)} h / (s (p + h)), h = H_1 sqrt(alpha_S);
   since Eq. 3b *adds* the two erfc, it must subtract both E terms:
   e_MR,n = E(a_n) + E(b_n), not the printed E(a) - E(b). Evidence: with
   n-dependent terms, the "+" version is closer to the exact interface
   temperature for every R tried (steel, t <= 20 s, max |error| 0.028 vs 0.051
   at R = 6.5e-4, 0.047 vs 0.122 at R = 3e-3 m^2 K/W).
5. **Eq. 8: prefactor.** psi = 1 - theta_S(d) carries Eq. 3a's (4a's)
   beta_M / (beta_S + beta_M) = (1 - gamma)/2, not the printed (1 + gamma)/2.
   Evidence (R = 0, t << L^2/alpha_S, i.e. the L -> inf limit where n = 0 is
   exact): the printed psi is (1 + gamma)/(1 - gamma) = beta_S/beta_M times the
   exact one, 0.16 for steel (at t = 1 s, L = 650 um: printed 0.072, exact 0.445).
6. **Eq. 7 (and Eq. 8) keep only n = 0.** Exact only for t << L^2 / alpha_S
   (or L -> inf); at R = 0, L = 650 um, steel, t = 20 s the n = 0 term
   underestimates the interface theta by 0.080 (1.3 K for 36 / 20 degC). The
   corrected forms sum all n.

What is *not* corrected (it is the closed form's nature, not a misprint):
with R > 0 the exact image ratio is Gamma(p) = (p + h_2) / (p + h_1), which
tends to 1 at high frequency, not to the constant gamma; the corrected forms
are therefore exact at R = 0 and approximate for R > 0 (the error is measured
by ``thermocue bench model`` and by ``Contact(..., tolerance=)``).

References
----------
.. [1] "How the Skin Thickness and Thermal Contact Resistance Influence Thermal
   Tactile Perception", Eqs. 3a, 3b, 4a, 4b, 7, 8.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import erfc

from ._special import exp_erfc
from .errors import ModelInputError

__all__ = ["PaperParameters", "eq3a", "eq4a", "eq3b", "eq4b", "eq7", "eq8", "evaluate"]

_EPS = 1e-17
_ERFC_CUT = 6.5      # erfc(6.5) = 3.8e-20, exp(-6.5^2) = 4.4e-19


@dataclass(frozen=True)
class PaperParameters:
    """Inputs of the closed forms (SI): skin L, alpha_S, beta_S, lambda_S; material alpha_M, beta_M; R."""

    L: float
    alpha_s: float
    beta_s: float
    lambda_s: float
    alpha_m: float
    beta_m: float
    R: float

    @property
    def mu(self) -> float:
        return math.sqrt(self.alpha_s / self.alpha_m)

    @property
    def gamma(self) -> float:
        return (self.beta_s - self.beta_m) / (self.beta_s + self.beta_m)

    @property
    def H1(self) -> float:
        """(beta + 1) / (R lambda_S), 1/m; inf for R = 0."""
        if self.R == 0.0:
            return math.inf
        return (self.beta_s / self.beta_m + 1.0) / (self.R * self.lambda_s)

    @classmethod
    def from_contact(cls, skin, material, resistance):
        return cls(skin.thickness, skin.diffusivity, skin.effusivity, skin.conductivity,
                   material.diffusivity, material.effusivity, float(resistance))


def _E(P, z, a):
    """exp(H1 z + H1^2 a^2) erfc(H1 a + z / 2a), stably; 0 when R = 0."""
    if P.R == 0.0:
        return np.zeros(np.broadcast(z, a).shape)
    return exp_erfc(P.H1 * a, z / (2.0 * a))


def _n_terms(P):
    g = abs(P.gamma)
    if g == 0.0:
        return 1
    return int(math.ceil(math.log(_EPS) / math.log(g))) + 1


def _series(P, a, term, shift=0.0):
    """sum_n (-gamma)^n term(n, a_active) over the t where the term is not negligible.

    Every distance z in term n is >= 2nL - shift, and every function of z in a
    term is bounded by exp(-(z / 2a)^2) or erfc(z / 2a): beyond the cut it is < 1e-18.
    """
    total = np.zeros_like(a)
    g = P.gamma
    for n in range(_n_terms(P)):
        dist = 2 * n * P.L - shift
        act = dist / (2.0 * a) < _ERFC_CUT
        if not np.any(act):
            break
        total[act] += (-g) ** n * term(n, a[act])
    return total


def _times(t):
    t = np.asarray(t, dtype=float)
    if np.any(~np.isfinite(t)) or np.any(t <= 0):
        raise ModelInputError(f"paper_forms: t: expected finite times > 0 s, got {t!r}")
    return t


def eq3a(P: PaperParameters, x: float, t, printed: bool = False):
    r"""theta_S(x, t) in the skin, Eq. 3a (= Eq. 4a), 0 <= x <= L.

    Parameters
    ----------
    P : PaperParameters
    x : float, m
    t : array_like, s (> 0)
    printed : bool
        True: e_SR as printed (n = 0 distances in every term). False: corrected.

    Returns
    -------
    ndarray, dimensionless

    Examples
    --------
    >>> P = PaperParameters(650e-6, 0.34 / (1200 * 3340), 1167.36, 0.34, 14.9 / (7900 * 447), 7253.71, 0.0)
    >>> float(eq3a(P, 0.0, 5.0))   # the inner boundary stays at theta = 1
    1.0
    """
    t = _times(t)
    a = np.sqrt(P.alpha_s * t)
    L = P.L

    def braces(n, aa):
        c, d = (2 * n + 1) * L - x, (2 * n + 1) * L + x
        out = erfc(c / (2 * aa)) - erfc(d / (2 * aa))
        if not printed:
            out = out - (_E(P, c, aa) - _E(P, d, aa))
        return out

    s = _series(P, a, braces)
    if printed:  # e_SR with n = 0 distances, the same in every term: sum (-gamma)^n = 1 / (1 + gamma)
        s = s - (_E(P, L - x, a) - _E(P, L + x, a)) / (1.0 + P.gamma)
    return 1.0 - (1.0 - P.gamma) / 2.0 * s


def _material(P, x, t, printed, second_offset):
    t = _times(t)
    a = np.sqrt(P.alpha_s * t)
    L = P.L
    y = P.mu * (x - L)

    def braces(n, aa):
        first = 2 * n * L - y if printed else 2 * n * L + y
        second = (2 * n + second_offset) * L + y
        out = erfc(first / (2 * aa)) + erfc(second / (2 * aa))
        if not printed:
            out = out - _E(P, first, aa) - _E(P, second, aa)
        return out

    s = _series(P, a, braces, shift=y if printed else 0.0)
    if printed:  # e_MR as printed: E(mu(x-L)) - E(2L + mu(x-L)), the same for every n
        s = s - (_E(P, y, a) - _E(P, 2 * L + y, a)) / (1.0 + P.gamma)
    return (1.0 + P.gamma) / 2.0 * s


def eq3b(P: PaperParameters, x: float, t, printed: bool = False):
    """theta_M(x, t) in the material, Eq. 3b, x >= L (printed or corrected; see module Notes)."""
    return _material(P, x, t, printed, 2)


def eq4b(P: PaperParameters, x: float, t, printed: bool = False):
    """theta_M(x, t), Eq. 4b: as Eq. 3b but printed with (2n+1)L in the second erfc.

    The corrected Eq. 4b is the corrected Eq. 3b (they are the same formula).
    """
    return _material(P, x, t, printed, 1 if printed else 2)


def eq7(P: PaperParameters, t, printed: bool = False):
    """Interface temperature on the material side, theta_M(L+, t), Eq. 7.

    Printed: the n = 0 term of Eq. 3b at x = L+ with the printed e_MR.
    Corrected: the corrected Eq. 3b at x = L+, all n.

    Examples
    --------
    >>> P = PaperParameters(650e-6, 0.34 / (1200 * 3340), 1167.36, 0.34, 14.9 / (7900 * 447), 7253.71, 0.0)
    >>> round(24 + 11 * 2 * (1 + P.gamma) / 2, 2)   # Eq. 7 (R = 0) never exceeds this, docs/design.md
    27.05
    >>> bool(24 + 11 * eq7(P, 20.0, printed=True) < 27.05)
    True
    """
    if not printed:
        return _material(P, P.L, t, False, 2)
    t = _times(t)
    a = np.sqrt(P.alpha_s * t)
    L = P.L
    br = 1.0 + erfc(L / a) - (_E(P, 0.0 * a, a) - _E(P, 2 * L, a))
    return (1.0 + P.gamma) / 2.0 * br


def eq8(P: PaperParameters, d: float, t, printed: bool = False):
    """Relative recognizing profile psi(t) = 1 - theta_S(d, t), Eq. 8.

    Printed: (1 + gamma)/2 {erfc((L-d)/2a) - erfc((L+d)/2a) - e_SR(d)}, n = 0.
    Corrected: 1 - (corrected Eq. 3a at x = d), prefactor (1 - gamma)/2, all n.
    """
    if not printed:
        return 1.0 - eq3a(P, d, t, printed=False)
    t = _times(t)
    a = np.sqrt(P.alpha_s * t)
    L = P.L
    br = erfc((L - d) / (2 * a)) - erfc((L + d) / (2 * a)) - (_E(P, L - d, a) - _E(P, L + d, a))
    return (1.0 + P.gamma) / 2.0 * br


def evaluate(P: PaperParameters, quantity: str, x: float, t, printed: bool):
    """Dispatch used by :class:`stimuli.Contact`; t = 0 gets the initial value."""
    t = np.asarray(t, dtype=float)
    out = np.empty_like(t)
    pos = t > 0
    at_L = quantity.startswith("interface")
    if quantity == "psi":
        out[~pos] = 0.0
    elif quantity in ("skin", "interface_skin"):
        out[~pos] = P.beta_s / (P.beta_s + P.beta_m) if (P.R == 0 and (at_L or x == P.L)) else 1.0
    else:
        out[~pos] = P.beta_s / (P.beta_s + P.beta_m) if (P.R == 0 and (at_L or x == P.L)) else 0.0
    tp = t[pos]
    if tp.size:
        if quantity == "interface_material":
            v = eq7(P, tp, printed)
        elif quantity == "interface_skin":
            v = eq3a(P, P.L, tp, printed)
        elif quantity == "skin":
            v = eq3a(P, x, tp, printed)
        elif quantity == "material":
            v = eq3b(P, x, tp, printed)
        elif quantity == "psi":
            v = eq8(P, x, tp, printed)
        else:
            raise ModelInputError(f"paper_forms: quantity: unknown {quantity!r}")
        out[pos] = v
    return out


#: Eq. 4a is Eq. 3a written for T_S (the same formula; prefactor (1 - gamma)/2).
eq4a = eq3a

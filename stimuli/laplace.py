r"""The exact contact problem in the Laplace domain (docs/design.md, "The physics").

Skin slab 0 < x < L held at theta = 1 at x = 0; material x > L, a half-space or
a slab of thickness D with an insulated back; contact resistance R at x = L.
With p = sqrt(s), q_i = p / sqrt(alpha_i) and beta_i = sqrt(lambda_i rho_i c_i):

.. math::

   \hat F(s) = \frac{1/s}{R + \tanh(q_S L)/(\beta_S p) + Z_M(s)},\quad
   Z_M = \frac{1}{\beta_M p}\ \text{(half-space)},\quad
   Z_M = \frac{\coth(q_M D)}{\beta_M p}\ \text{(slab)}

   \hat\theta_S(x) = \frac1s - \hat F\,K_S(x),\quad
   K_S = \frac{\sinh(q_S x)}{\beta_S p \cosh(q_S L)},\qquad
   \hat\theta_M(x) = \hat F\,K_M(x),\quad
   K_M = \frac{e^{-q_M (x - L)}}{\beta_M p}\ \text{or}\
   \frac{\cosh(q_M (L + D - x))}{\beta_M p \sinh(q_M D)}.

F is the interface heat flux divided by (T_S0 - T_M0) (W/m^2/K). Every
hyperbolic function is written with ``exp(-2 q ...)`` factors, which are
bounded by 1 because Re q >= 0 on the principal branch, so nothing overflows
anywhere on an inversion contour; ``1 - exp(-z)`` goes through ``expm1``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ContactTransform"]


@dataclass(frozen=True)
class ContactTransform:
    """Laplace-domain kernels of one contact (all SI).

    Parameters
    ----------
    L : float, m
        Skin thickness.
    alpha_s, beta_s : float, m^2/s and W s^1/2/(m^2 K)
        Skin diffusivity and effusivity.
    alpha_m, beta_m : float
        Material diffusivity and effusivity.
    R : float, m^2 K/W
        Contact resistance (0 allowed).
    D : float or None, m
        Material slab thickness; None for a half-space.
    """

    L: float
    alpha_s: float
    beta_s: float
    alpha_m: float
    beta_m: float
    R: float
    D: float | None = None

    @classmethod
    def from_contact(cls, skin, material, resistance) -> "ContactTransform":
        return cls(skin.thickness, skin.diffusivity, skin.effusivity, material.diffusivity,
                   material.effusivity, float(resistance), material.thickness)

    # -- pieces ---------------------------------------------------------------
    def _skin_impedance(self, p, qs):
        e = np.exp(-2.0 * qs * self.L)
        return -np.expm1(-2.0 * qs * self.L) / ((1.0 + e) * self.beta_s * p)

    def _material_impedance(self, p):
        if self.D is None:
            return 1.0 / (self.beta_m * p)
        qm = p / np.sqrt(self.alpha_m)
        e = np.exp(-2.0 * qm * self.D)
        return (1.0 + e) / (-np.expm1(-2.0 * qm * self.D) * self.beta_m * p)

    def flux(self, s):
        """F(s): transform of the interface flux / (T_S0 - T_M0), W/(m^2 K) * s."""
        return self._flux_pq(*self._nodes(s))

    def _nodes(self, s):
        s = np.asarray(s, dtype=complex)
        p = np.sqrt(s)
        return s, p, p / np.sqrt(self.alpha_s)

    def _flux_pq(self, s, p, qs):
        return 1.0 / (s * (self.R + self._skin_impedance(p, qs) + self._material_impedance(p)))

    def skin_deficit(self, s, x):
        """Transform of 1 - theta_S(x, t) = F K_S(x), for 0 <= x <= L."""
        s, p, qs = self._nodes(s)
        F = self._flux_pq(s, p, qs)
        kern = (np.exp(-qs * (self.L - x)) * -np.expm1(-2.0 * qs * x)
                / ((1.0 + np.exp(-2.0 * qs * self.L)) * self.beta_s * p))
        return F * kern

    def material_rise(self, s, x):
        """Transform of theta_M(x, t) = F K_M(x), for x >= L (x <= L + D for a slab)."""
        s, p, qs = self._nodes(s)
        F = self._flux_pq(s, p, qs)
        qm = p / np.sqrt(self.alpha_m)
        xi = x - self.L
        if self.D is None:
            kern = np.exp(-qm * xi) / (self.beta_m * p)
        else:
            kern = ((np.exp(-qm * xi) + np.exp(-qm * (2.0 * self.D - xi)))
                    / (-np.expm1(-2.0 * qm * self.D) * self.beta_m * p))
        return F * kern

"""Eq. 5 of the paper: thermal contact resistance from surface roughness."""
from __future__ import annotations

import math
import warnings

import numpy as np

from .errors import ModelInputError, ModelRangeWarning
from .properties import Material, Skin

__all__ = ["contact_resistance", "GRAM_FORCE_PER_MM2", "PAPER_HARDNESS", "P_OVER_H_WARN"]

#: 1 gram-force per square millimetre in pascal: 1e-3 kg * 9.80665 m/s^2 / 1e-6 m^2.
GRAM_FORCE_PER_MM2 = 1e-3 * 9.80665 / 1e-6

#: Eq. 5 (a plastic-contact correlation, h ~ (P/H)^0.95) is a light-load law: the real contact
#: area fraction is about P/H, and the asperity contacts stop being independent as it grows.
#: The paper's 2 N over 135 mm^2 is P/H = 0.12; a warning is given above 0.3 (5 N), and
#: P >= H (a real contact area larger than the apparent one) is refused.
P_OVER_H_WARN = 0.3

#: The paper's skin microhardness H = 12.5 gf/mm^2, in Pa (= 122583.125 Pa).
PAPER_HARDNESS = 12.5 * GRAM_FORCE_PER_MM2


def contact_resistance(roughness, skin: Skin | None = None, material: Material | None = None, *,
                       force: float = 2.0, area: float = 135e-6, slope: float = 0.3,
                       hardness: float = PAPER_HARDNESS, skin_roughness: float = 21.69e-6):
    r"""Skin-material thermal contact resistance, Eq. 5 of [1]_.

    Parameters
    ----------
    roughness : float or array_like, m
        R_a of the material surface (the paper's samples: 0.4e-6 ... 100e-6). 0 is allowed.
    skin : Skin, optional
        Supplies lambda_S (default: :class:`Skin` defaults, 0.34 W/(m K)).
    material : Material, optional
        Supplies lambda_a, see Notes (default: stainless steel, 14.9 W/(m K)).
    force : float, N
        Contact force F (paper: 2 N).
    area : float, m^2
        Apparent contact area A (paper: 135 mm^2 = 135e-6 m^2); P = F / A in Pa.
    slope : float, dimensionless
        Effective absolute mean asperity slope Delta_a (paper: 0.3).
    hardness : float, Pa
        Skin microhardness H. The paper's "H = 12.5 g/mm^2" is gram-force per
        mm^2: 12.5 * 9.80665e-3 N / 1e-6 m^2 = 122583.125 Pa (the default).
    skin_roughness : float, m
        R_S, the skin's rms roughness (paper: 21.69 um).

    Returns
    -------
    float or ndarray, m^2 K / W

    Raises
    ------
    ModelInputError
        Negative roughness, non-positive force/area/slope/hardness, a pressure F / A >= H.

    Warns
    -----
    ModelRangeWarning
        P/H above :data:`P_OVER_H_WARN` (Eq. 5 assumes P << H).

    Notes
    -----
    .. math:: R_c = \frac{0.8\,R_q}{\lambda_{SF}\,\Delta_a}\left(\frac{H}{P}\right)^{0.95},\quad
              R_q = \sqrt{R_S^2 + R_a^2},\quad
              \lambda_{SF} = \frac{2\lambda_S\lambda_a}{\lambda_S + \lambda_a}

    Units: R_q in m, lambda in W/(m K), so R_q / lambda is m^2 K / W; H / P is a
    pure number once both are in Pa (with the paper's values H/P = 8.27).

    *Interpretation of lambda_a.* Eq. 5 is the Cooper-Mikic-Yovanovich
    plastic-contact correlation, h_c = 1.25 k_s m / sigma (P/H)^0.95, in which
    k_s = 2 k_1 k_2 / (k_1 + k_2) is the harmonic mean of the conductivities of
    the **two contacting solids**. We therefore take lambda_a as the contacted
    material's conductivity. The alternative, the gap medium (air, 0.026 W/(m K)),
    would give R = 9e-3 m^2 K/W even for a smooth sample, about five times the
    whole skin's resistance L / lambda_S (1.9e-3 for L = 650 um), i.e. an almost
    insulating contact, which contradicts the large temperature drops measured on
    steel (Fig. 8, Table 2). With lambda_a = lambda_steel, lambda_SF = 0.665
    W/(m K) and R grows from 6.49e-4 (R_a = 1.6 um) to 3.05e-3 m^2 K/W (100 um).
    Nothing here was fitted to Table 2.

    References
    ----------
    .. [1] "How the Skin Thickness and Thermal Contact Resistance Influence
       Thermal Tactile Perception", Eq. 5; its Ref. [15] for the parameters.

    Examples
    --------
    >>> round(PAPER_HARDNESS, 3)
    122583.125
    >>> f"{contact_resistance(1.6e-6):.4e}"
    '6.4945e-04'
    >>> float(contact_resistance(0.0)) > 0   # the skin's own roughness remains
    True
    """
    from .materials import material as _material

    skin = Skin(1e-3) if skin is None else skin
    material = _material("stainless_steel") if material is None else material
    where = "contact_resistance"
    for name, v in (("force", force), ("area", area), ("slope", slope), ("hardness", hardness)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ModelInputError(f"{where}: {name}: expected a finite number > 0, got {v!r}")
    if not (isinstance(skin_roughness, (int, float)) and math.isfinite(skin_roughness)
            and skin_roughness >= 0):
        raise ModelInputError(f"{where}: skin_roughness: expected a number >= 0 (m), got {skin_roughness!r}")
    ra = np.asarray(roughness, dtype=float)
    if not np.all(np.isfinite(ra)) or np.any(ra < 0):
        raise ModelInputError(f"{where}: roughness: expected finite values >= 0 (m), got {roughness!r}")
    if np.any(ra > 1e-2):
        raise ModelInputError(f"{where}: roughness: expected metres (e.g. 1.6e-6), got {roughness!r}")
    lam_s, lam_a = skin.conductivity, material.conductivity
    lam_sf = 2.0 * lam_s * lam_a / (lam_s + lam_a)
    pressure = force / area
    ratio = pressure / hardness
    if ratio >= 1.0:
        raise ModelInputError(f"{where}: force: expected a pressure F / A below the skin's "
                              f"hardness H = {hardness:.4g} Pa (Eq. 5 needs P << H), got "
                              f"{force!r} N over {area!r} m^2 = {pressure:.4g} Pa (P/H = {ratio:.3g})")
    if ratio > P_OVER_H_WARN:
        warnings.warn(f"{where}: force: P/H = {ratio:.3g} (F = {force!r} N over {area!r} m^2) "
                      f"approaches the limit of Eq. 5's light-load correlation (P << H; warned "
                      f"above {P_OVER_H_WARN:g})", ModelRangeWarning, stacklevel=2)
    rq = np.hypot(skin_roughness, ra)
    r = 0.8 * rq / (lam_sf * slope) * (hardness / pressure) ** 0.95
    return float(r) if r.ndim == 0 else r

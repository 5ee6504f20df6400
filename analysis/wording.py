"""How the report writes numbers: p-values and signed values (one concept).

``p = 0.000`` reads as "impossible under the null" and ``-0.0`` as a negative difference:
:func:`p_text` writes ``p < 0.001`` below 0.001, :func:`signed` writes a value that rounds
to zero without a sign.
"""
from __future__ import annotations

import math

__all__ = ["p_text", "signed", "df_text"]


def p_text(p, digits: int = 3) -> str:
    """``p = 0.042``, ``p < 0.001`` (below ``10**-digits``), ``p not computed`` (NaN).

    >>> p_text(0.0004), p_text(0.0426), p_text(float("nan"))
    ('p < 0.001', 'p = 0.043', 'p not computed')
    """
    if p is None or not math.isfinite(float(p)):
        return "p not computed"
    floor = 10.0 ** -digits
    return f"p < {floor:.{digits}f}" if p < floor else f"p = {p:.{digits}f}"


def df_text(df) -> str:
    """Degrees of freedom as printed: ``28`` (a whole number), ``11.3`` (Satterthwaite).

    >>> df_text(28.0), df_text(11.34)
    ('28', '11.3')
    """
    return f"{df:.0f}" if abs(df - round(df)) < 1e-9 else f"{df:.1f}"


def signed(value, digits: int = 1) -> str:
    """``+1.2``, ``-3.4``; ``0.0`` for a value that rounds to zero (never ``-0.0``).

    >>> signed(-0.04), signed(0.04), signed(-1.25, 2)
    ('0.0', '0.0', '-1.25')
    """
    text = f"{value:+.{digits}f}"
    return f"{0:.{digits}f}" if float(text) == 0 else text

"""The models' design in patsy's terms: the design matrices a model is fitted on
(:func:`design_matrices`, with the text columns given to patsy as categoricals,
:func:`patsy_frame`) and a fitted model's design rows of given levels (:func:`design_rows`: the
rows of every contrast, each built once per fit, :class:`analysis.models.ModelFit`'s
``built_rows``).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import patsy

__all__ = ["design_matrices", "design_rows", "patsy_frame"]


def design_matrices(formula: str, data: pd.DataFrame):
    y, x = patsy.dmatrices(formula, patsy_frame(data), return_type="dataframe")
    return y.iloc[:, 0].to_numpy(), x


def patsy_frame(data: pd.DataFrame) -> pd.DataFrame:
    """``data`` with its text columns as pandas Categoricals (their sorted values the
    categories), for patsy: the same levels, in the same order, as patsy finds in the text
    itself, hence the same design matrices; but patsy reads a Categorical's codes at once,
    and walks a column of text value by value (to find its levels, then to code it: ~15 ms a
    model on 720 trials). Numbers are left as they are (a formula may use them as numbers)."""
    text = [c for c in data.columns if pd.api.types.is_string_dtype(data[c])
            and not isinstance(data[c].dtype, pd.CategoricalDtype)]
    if not text:
        return data
    return data.assign(**{c: pd.Categorical(data[c]) for c in text})


def design_rows(fit: "ModelFit", groups, modes, samples) -> np.ndarray:
    """The fitted model's design rows (``fit.design_info``) of every (group, mode, sample) of
    ``groups x modes x samples``, in that order (group slowest): the rows of the contrasts.

    A row depends only on its own levels, so each is built once per fit (patsy's
    ``build_design_matrices`` costs ~4 ms a call however few rows; the fidelity table alone
    asks for 76 sets of rows) and the rows asked for later are taken from that store: the
    same doubles.
    """
    keys = [(g, m, r) for g in groups for m in modes for r in samples]
    new = list(dict.fromkeys(k for k in keys if k not in fit.built_rows))
    if new:
        grid = pd.DataFrame([(g, m, r, 0, "x") for g, m, r in new],
                            columns=["group", "mode", "roughness_id", "correct", "participant"])
        built = np.asarray(patsy.build_design_matrices([fit.design_info], grid)[0])
        fit.built_rows.update(zip(new, built))
    return np.array([fit.built_rows[k] for k in keys])

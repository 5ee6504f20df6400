"""The random-slope model's SD profile ends at a singular fit (correlation estimated at +-1).

There the profile over an SD has more than one minimum near its upper end: a degenerate one (the
correlation held at +-1, or the other SD at 0), which a warm start from it never leaves, and one
with the correlation inside (-1, 1), lower. An end computed on the first is too low: the
interval too narrow. The reference here is the profile's definition itself: at the end, the
deviance minimised from five correlations (-0.997 to 0.997) has risen by exactly the cut-off."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from analysis.glmm import profile_cut
from analysis.glmm_slope import fit_glmm_slope
from analysis.glmm_slope_profile import _sd_params, is_singular, lowest_deviance, profile_end
from analysis.models import FORMULA
from generator import generate, null_cells


@pytest.fixture(scope="module")
def singular():
    """A 15 + 15 study with no slope variance whose fit puts the correlation at +-1."""
    trials = generate(null_cells(), n_a=15, n_b=15, slope_sd=0.0, seed=101003)
    pieces = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit_glmm_slope(trials, FORMULA, submit=lambda f, *a: pieces.append(a) or None)
    return pieces[0]


def _rise_above_cut(args, which: int, value: float) -> float:
    """The deviance's rise at ``value`` of SD ``which``, the lowest of five starts, less the
    cut-off (0 at an end of the interval)."""
    data, z, theta, dev_min, n_agq, level, df, *_, modes = args
    return (lowest_deviance(data, z, theta, n_agq, modes, which, value) - dev_min
            - profile_cut(level, df))


@pytest.mark.slow
def test_sd_upper_ends_at_a_singular_fit_are_where_the_lowest_profile_crosses(singular):
    data, z, theta, dev_min, n_agq, level, df, *_, modes = singular
    assert abs(np.sin(_sd_params(theta[-3:])[2])) == pytest.approx(1.0)    # the premise
    assert is_singular(theta) and not is_singular(np.r_[theta[:-3], 0.5, 0.1, 0.3])
    for which in (0, 1):                                   # the intercept's SD, the slope's
        end = profile_end(data, z, theta, dev_min, n_agq, level, df, which, 1, modes)
        assert abs(_rise_above_cut(singular, which, end)) < 0.01, which
        # without the extra starts the end stops on the degenerate branch, inside the interval:
        # the lowest profile there is still well below the cut-off
        old = profile_end(data, z, theta, dev_min, n_agq, level, df, which, 1, modes,
                          off_boundary=False)
        assert old < end - 0.05 and _rise_above_cut(singular, which, old) < -0.5, which

"""analysis.statsmodels_engine: statsmodels loads with its patsy engine, formulaic not imported
(the analysis modules that fit statsmodels models load it on import)."""
import os
import subprocess
import sys

import pytest

SCRIPT = """
import sys
import analysis.models          # the module that fits statsmodels models
from statsmodels.genmod.generalized_estimating_equations import GEE
import statsmodels.formula._manager as manager
print(manager.DEFAULT_FORMULA_ENGINE, 'formulaic' in sys.modules)
import formulaic                     # hidden only while statsmodels loaded
print(formulaic.__name__)
"""


@pytest.mark.slow      # a fresh interpreter importing pandas, SciPy and statsmodels: 3-8 s
def test_statsmodels_uses_patsy_without_importing_formulaic():
    env = {k: v for k, v in os.environ.items() if k != "SM_FORMULA_ENGINE"}
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, env=env,
                          check=True)
    assert done.stdout.split() == ["patsy", "False", "formulaic"]

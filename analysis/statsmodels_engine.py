"""statsmodels without formulaic: the formula machinery it loads, minus an unused engine.

statsmodels (0.15) imports ``statsmodels.formula._manager`` with every model class, and that
module imports both formula engines it knows, patsy and formulaic, though it uses patsy whenever
patsy is installed (``SM_FORMULA_ENGINE`` unset). formulaic pulls in narwhals: ~0.1-0.2 s of
CPU (more on a busy machine) on every ``thermocue analyze``, before anything else can run, for
an engine the analysis never uses (its design matrices
are patsy's, :func:`analysis.design.design_matrices`). :func:`load` imports that module once
with ``formulaic`` hidden, so statsmodels records it as absent and takes patsy, as it would
anyway; afterwards ``import formulaic`` works again for anyone who wants it. Nothing is hidden
when ``SM_FORMULA_ENGINE=formulaic`` asks for it, when patsy is missing, or when formulaic or
statsmodels' formula manager is already loaded.
"""
from __future__ import annotations

import importlib.util
import os
import sys

__all__ = ["load"]


def load() -> None:
    """Import ``statsmodels.formula._manager`` (patsy engine) without importing formulaic."""
    if ("statsmodels.formula._manager" in sys.modules or "formulaic" in sys.modules
            or os.environ.get("SM_FORMULA_ENGINE") == "formulaic"
            or importlib.util.find_spec("patsy") is None):
        return
    sys.modules["formulaic"] = None          # `import formulaic` raises ImportError meanwhile
    try:
        import statsmodels.formula._manager  # noqa: F401
    except ImportError:                      # statsmodels missing or laid out differently
        pass
    finally:
        if "formulaic" in sys.modules and sys.modules["formulaic"] is None:
            del sys.modules["formulaic"]

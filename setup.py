"""The one thing pyproject.toml cannot say yet without an experimental table: the C extension.

``experiments/hardware/_tick.c``, the emulated firmware's steady ticks compiled
(``experiments/hardware/compiled_tick.py``). Optional: a machine without a C compiler installs the
package anyway and runs Python's ticks (the same logs, about 3 times slower).
``-ffp-contract=off``: no fused multiply-add, so that every double is the Python tick's.
"""
import sys

from setuptools import Extension, setup

flags = [] if sys.platform == "win32" else ["-O2", "-ffp-contract=off"]
setup(ext_modules=[Extension("experiments.hardware._tick", ["experiments/hardware/_tick.c"],
                             extra_compile_args=flags, optional=True)])

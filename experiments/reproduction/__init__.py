"""The paper's model results recomputed from :mod:`stimuli`: its Figs. 3-6 and Table 2.

Not analysis of logs (that is :mod:`analysis`) and not a simulated study (that is
:mod:`experiments.simulation`): each module here evaluates the thermal model at the paper's
parameters and writes the figures or the table beside the paper's own numbers, with residuals.

- :mod:`.model_figures`: Figs. 3-6, the paper's forms (printed and corrected) beside the exact
  solution (``thermocue reproduce figures``).
- :mod:`.table2`: Table 2 beside our models (``thermocue reproduce table2``).

They import :mod:`stimuli` (and numpy, matplotlib) only; ``tests/test_import_layers.py`` checks it.
"""

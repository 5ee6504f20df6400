"""The pyserial port both emulators are served through in this process (:mod:`.emulated_port`).

Its own package, below :mod:`experiments.emulators.thermocue` and :mod:`experiments.emulators.tcs2`
(which subclass it) and below the modules that serve both (``backends``, ``pty_server``).
"""

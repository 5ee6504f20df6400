"""The one place that configures logging: the ``thermocue`` logger, for the command line.

Library modules log progress on ``logging.getLogger("thermocue.<area>")`` (``thermocue.study``,
``thermocue.session``, ``thermocue.analysis``, ...) and configure no handlers: used as a library,
their INFO lines go nowhere (Python's last-resort handler shows only warnings). The command line
runs every command inside :func:`configure_logging`: one handler on ``thermocue`` writing the bare
message to stderr, level INFO, or WARNING with ``--quiet``.
"""
from __future__ import annotations

import logging
import sys
from contextlib import contextmanager

__all__ = ["configure_logging", "LOGGER_NAME"]

#: The root of every logger of the package.
LOGGER_NAME = "thermocue"


class _StderrHandler(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is when a record is emitted (not when the handler was
    made): a test's captured stderr, or the terminal."""

    def __init__(self):
        super().__init__(sys.stderr)

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):   # StreamHandler.__init__ assigns it; the property ignores it
        pass


@contextmanager
def configure_logging(quiet: bool = False):
    """Show the package's log lines on stderr while a command runs: INFO and above, or WARNING
    and above if ``quiet``.

    A context manager: on leaving it the ``thermocue`` logger is as it was (``main`` runs many
    times in one process in the tests, and a program embedding it keeps its own settings), so no
    line is ever written twice and library use stays quiet.

    Parameters
    ----------
    quiet : bool
        ``--quiet``: only warnings and errors.

    Yields
    ------
    logging.Logger
        The ``thermocue`` logger.
    """
    logger = logging.getLogger(LOGGER_NAME)
    handler = _StderrHandler()
    handler.setFormatter(logging.Formatter("%(message)s"))
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.WARNING if quiet else logging.INFO)
    try:
        yield logger
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)

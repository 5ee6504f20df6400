"""Protocols, schedules, sessions, the thermal display and responders."""


def thermocue_version() -> str:
    """The installed package's version (``"unknown"`` when run from an uninstalled tree)."""
    # lazy: importlib.metadata costs ~18 ms and every import of experiments (logformat, the CLI's
    # --help) runs this file
    from importlib import metadata
    try:
        return metadata.version("thermocue")
    except metadata.PackageNotFoundError:   # pragma: no cover - the package is installed
        return "unknown"

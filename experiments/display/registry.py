"""The display backends by URL scheme, and :func:`open_display`, the one way to open a display.

A backend registers itself by subclassing :class:`~.display_base.Display` with ``scheme=``
(as PsychoPy's devices register by subclassing ``BaseDevice``). The built-in backends live in
the modules of :data:`BUILTIN_MODULES`, imported on first lookup so that importing the package
does not start QEMU's or the thermode's code; a third-party backend is a module listed under the
``thermocue.displays`` entry-point group (imported the same way: the emulators register
``emulator://`` so, from :mod:`experiments.emulators.backends`, which the display never imports),
or any module imported before the display is opened.

URL grammar: ``SCHEME://REST``; a URL without ``://`` (``/dev/ttyUSB0``, ``COM3``, a pty path)
is the thermocue display protocol on a serial port (scheme ``serial``). pyserial's own URL
schemes (``loop://``, ``socket://``, ``rfc2217://``, ``spy://``) also reach the thermocue
protocol's driver.
"""
from __future__ import annotations

import importlib
import threading

from experiments.errors import UserInputError

__all__ = ["open_display", "backend_for", "backends", "register", "scheme_of", "BUILTIN_MODULES"]

#: Modules that define the built-in backends (each registers its classes on import).
BUILTIN_MODULES = (
    "experiments.display.thermocue.driver",          # serial: a path or a pyserial URL
    "experiments.display.thermocue.qemu_firmware",   # qemu-firmware://: the C firmware under QEMU
    "experiments.display.tcs2.backend",              # tcs2://: a QST.Lab TCS II thermode
)

#: The entry-point group of third-party backends.
ENTRY_POINT_GROUP = "thermocue.displays"

#: pyserial's URL schemes, served by the thermocue protocol's serial backend.
PYSERIAL_SCHEMES = ("loop", "socket", "rfc2217", "spy", "hwgrep", "alt", "cp2110")

_REGISTRY: dict = {}
_LOADED = False
_LOCK = threading.Lock()


def register(scheme: str, cls) -> None:
    """Register ``cls`` for URLs of ``scheme`` (called by ``Display.__init_subclass__``).

    Raises
    ------
    ValueError
        ``scheme`` is taken by another class (a backend cannot replace another silently).
    """
    key = scheme.lower()
    old = _REGISTRY.get(key)
    if old is not None and old is not cls and (old.__module__, old.__qualname__) != (
            cls.__module__, cls.__qualname__):
        raise ValueError(f"display registry: scheme {scheme!r} is already taken by "
                         f"{old.__module__}.{old.__qualname__}")
    _REGISTRY[key] = cls


def _load_builtins() -> None:
    global _LOADED
    with _LOCK:
        if _LOADED:
            return
        _LOADED = True
    for name in BUILTIN_MODULES:
        try:
            importlib.import_module(name)
        except ModuleNotFoundError as exc:
            # not (yet) in this installation: skip it; but a backend whose own import fails on
            # something it needs is an error to see
            if exc.name is None or not (name == exc.name or name.startswith(exc.name + ".")):
                raise
    try:
        from importlib.metadata import entry_points
        for ep in entry_points(group=ENTRY_POINT_GROUP):
            ep.load()
    except Exception as exc:   # a broken third-party plugin must not stop the built-in ones
        import warnings
        warnings.warn(f"display registry: a {ENTRY_POINT_GROUP} entry point failed to load: "
                      f"{exc}", RuntimeWarning, stacklevel=2)


def scheme_of(url: str) -> str:
    """The backend scheme of a display URL (``serial`` for a path or a pyserial URL)."""
    url = str(url)
    if "://" not in url:
        return "serial"
    scheme = url.split("://", 1)[0].lower()
    return "serial" if scheme in PYSERIAL_SCHEMES else scheme


def backend_for(url: str):
    """The backend class that opens ``url``.

    Raises
    ------
    UserInputError
        No backend is registered for the URL's scheme (the message lists those that are).
    """
    _load_builtins()
    scheme = scheme_of(url)
    try:
        return _REGISTRY[scheme]
    except KeyError:
        known = ", ".join(f"{s}://" for s in sorted(_REGISTRY) if s != "serial")
        raise UserInputError(f"display: {url!r}: no display backend for the scheme {scheme!r}; "
                             f"expected a serial device path or one of {known}") from None


def backends() -> list:
    """The registered backend classes, by scheme."""
    _load_builtins()
    return [_REGISTRY[s] for s in sorted(_REGISTRY)]


def open_display(url: str, limits=None, **options):
    """Open a display by URL: pick its backend, shake hands, keep the device alive.

    Parameters
    ----------
    url : str
        ``emulator://[?...]``, ``qemu-firmware://[?...]``, ``tcs2://PORT``, a serial device path
        (``/dev/ttyUSB0``) or a pty path, or a pyserial URL.
    limits : SafetyLimits, optional
        The protocol's safety limits (default: the protocol's defaults).
    **options
        Passed to the backend's ``open`` (``baudrate`` and the driver's keyword arguments for
        the thermocue protocol).

    Returns
    -------
    Display

    Raises
    ------
    UserInputError
        No backend for the scheme, or a malformed URL.
    DisplayError
        The device cannot be reached or is refused at the handshake.
    """
    return backend_for(url).open(str(url), limits, **options)

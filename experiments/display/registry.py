"""The display backends by URL scheme, and :func:`open_display`, the one way to open a display.

A backend registers itself by subclassing :class:`~.base.Display` with ``scheme=`` (as
PsychoPy's devices register by subclassing ``BaseDevice``). The built-in backends live in the
modules of :data:`BUILTIN_MODULES`, imported on first lookup so that importing the package does
not start QEMU's or the thermode's code; a third-party backend is a module named by an entry
point of the ``thermocue.displays`` group (imported the same way: the emulators register
``emulator://`` so, from :mod:`experiments.emulators.backends`, which the display never
imports), or any module imported before the display is opened.

A plugin is not trusted: one whose import raises, or calls ``sys.exit``, is refused, its
registrations undone, and it is listed by name with the reason (:func:`broken_plugins`,
``thermocue displays``); the other backends work on. pyserial's own URL schemes
(:data:`PYSERIAL_SCHEMES`) are reserved: they reach the thermocue protocol's serial backend,
and no plugin can claim one.

URL grammar: ``SCHEME://REST``; a URL without a scheme (``/dev/ttyUSB0``, ``COM3``, a pty path)
is the thermocue display protocol on a serial port (scheme ``serial``), and so are pyserial's
URLs (``loop://``, ``socket://``, ``rfc2217://``, ``spy://``, ``hwgrep://``). ``SCHEME:`` with
fewer than two slashes (``tcs2:/tmp/x``) is refused, not read as a path. Every URL error is one
line showing at most :data:`MAX_URL_SHOWN` characters of the URL (:func:`shown_url`).
"""
from __future__ import annotations

import importlib
import re
import threading

from experiments.errors import DisplayError, UserInputError

__all__ = ["open_display", "backend_for", "backends", "register", "scheme_of", "check_url",
           "parse_display_url",
           "broken_plugins", "shown_url", "BUILTIN_MODULES", "PYSERIAL_SCHEMES", "MAX_URL_SHOWN"]

#: Modules that define the built-in backends (each registers its classes on import).
BUILTIN_MODULES = (
    "experiments.display.thermocue.driver",          # serial: a path or a pyserial URL
    "experiments.display.thermocue.qemu_firmware",   # qemu-firmware://: the C firmware under QEMU
    "experiments.display.tcs2.backend",              # tcs2://: a QST.Lab TCS II thermode
)

#: The entry-point group of third-party backends.
ENTRY_POINT_GROUP = "thermocue.displays"

#: pyserial's URL schemes, served by the thermocue protocol's serial backend (reserved).
PYSERIAL_SCHEMES = ("loop", "socket", "rfc2217", "spy", "hwgrep", "alt", "cp2110")

#: The most characters of a URL an error message shows.
MAX_URL_SHOWN = 200

_REGISTRY: dict = {}
_BROKEN: dict = {}          # entry point name -> (the module it names, why it was refused)
_LOADED = False
_LOCK = threading.Lock()
_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]+):")


def register(scheme: str, cls) -> None:
    """Register ``cls`` for URLs of ``scheme`` (called by ``Display.__init_subclass__``).

    Raises
    ------
    ValueError
        ``scheme`` is taken by another class (a backend cannot replace another silently), is
        one of pyserial's (:data:`PYSERIAL_SCHEMES`), or is not a URL scheme.
    """
    key = str(scheme).lower()
    if key in PYSERIAL_SCHEMES:
        raise ValueError(f"display registry: scheme {scheme!r} is reserved: pyserial's "
                         f"{scheme}:// URLs reach the thermocue protocol's serial backend")
    if not re.fullmatch(r"[a-z][a-z0-9+.-]+", key):
        raise ValueError(f"display registry: scheme {shown_url(scheme)}: expected a URL scheme "
                         f"(a letter, then letters, digits, '+', '-' or '.')")
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
    from importlib.metadata import entry_points
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        _load_plugin(ep)


def _load_plugin(ep) -> None:
    """Import one ``thermocue.displays`` entry point; refuse it (registrations undone, listed
    by :func:`broken_plugins`) when its import raises or exits."""
    before = dict(_REGISTRY)
    try:
        ep.load()
    except KeyboardInterrupt:
        raise
    except BaseException as exc:        # SystemExit too: a plugin must not end the program
        _REGISTRY.clear()
        _REGISTRY.update(before)
        if isinstance(exc, SystemExit):
            why = f"its import called sys.exit({exc.code!r}); refused"
        else:
            why = f"its import failed: {type(exc).__name__}: {_one_line(str(exc))}"
        _BROKEN[ep.name] = (ep.value, why)
        import warnings
        warnings.warn(f"display registry: plugin {ep.name!r} ({ep.value}, entry point group "
                      f"{ENTRY_POINT_GROUP}): {why}", RuntimeWarning, stacklevel=3)


def broken_plugins() -> dict:
    """The refused plugins: entry point name -> ``(module, reason)``."""
    _load_builtins()
    return dict(_BROKEN)


def _one_line(text: str, limit: int = 300) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit] + "…"


def shown_url(url) -> str:
    """``url`` for a message: quoted, on one line, at most :data:`MAX_URL_SHOWN` characters of
    it (then how long it was)."""
    url = str(url)
    if len(url) <= MAX_URL_SHOWN:
        return repr(url)
    return f"{url[:MAX_URL_SHOWN]!r}… ({len(url)} characters)"


def _bounded(exc: Exception, url) -> Exception:
    """``exc`` with the URL shown by :func:`shown_url`, any other long piece of it (a backend
    quoting an option's value) cut to :data:`MAX_URL_SHOWN` characters, on one line."""
    url = str(url)
    text = str(exc)
    if len(url) > MAX_URL_SHOWN:
        short = shown_url(url)
        text = text.replace(repr(url), short).replace(url, short)
        text = re.sub(r"\S{%d,}" % (MAX_URL_SHOWN + 1),
                      lambda m: m.group(0) if m.group(0) in short else m.group(0)[:MAX_URL_SHOWN] + "…",
                      text)
    exc.args = (_one_line(text, 2 * MAX_URL_SHOWN + 400),) + tuple(exc.args[1:])
    return exc


class UnknownScheme(UserInputError):
    """A URL no registered backend opens. ``expected`` says, after "expected", what would be
    opened (a caller that names its own option words its line with it)."""

    def __init__(self, message: str, expected: str):
        super().__init__(message)
        self.expected = expected


def scheme_of(url: str) -> str:
    """The backend scheme of a display URL (``serial`` for a path or a pyserial URL).

    Raises
    ------
    UnknownScheme
        ``SCHEME:`` without ``//`` after it (``tcs2:/tmp/x``): not read as a path.
    """
    url = str(url)
    if "://" not in url:
        m = _SCHEME.match(url)
        if m is not None:     # a drive letter (C:) is one character: never a scheme here
            expected = (f"{m.group(1)}://... (a scheme is followed by two slashes; "
                        f"tcs2:///dev/ttyACM0 for a path) or a serial device path")
            raise UnknownScheme(f"display: {shown_url(url)}: expected {expected}", expected)
        return "serial"
    scheme = url.split("://", 1)[0].lower()
    return "serial" if scheme in PYSERIAL_SCHEMES else scheme


def backend_for(url: str):
    """The backend class that opens ``url``.

    Raises
    ------
    UnknownScheme
        No backend is registered for the URL's scheme (the message lists those that are).
    """
    _load_builtins()
    scheme = scheme_of(url)
    try:
        return _REGISTRY[scheme]
    except KeyError:
        known = ", ".join(f"{s}://" for s in sorted(_REGISTRY) if s != "serial")
        expected = f"a serial device path or one of {known}"
        raise UnknownScheme(f"display: {shown_url(url)}: no display backend for the scheme "
                            f"{shown_url(scheme)}; expected {expected}", expected) from None


def backends() -> list:
    """The registered backend classes, by scheme."""
    _load_builtins()
    return [_REGISTRY[s] for s in sorted(_REGISTRY)]


def parse_display_url(url):
    """``url`` parsed once by its backend (:meth:`Display.parse_url`; nothing opened): a
    :class:`~experiments.display.url.DisplayURL`, returned as it is when already one; every
    error one bounded line.

    Raises
    ------
    UserInputError
        No backend for the scheme, or a URL its backend refuses.
    """
    from .url import DisplayURL
    if isinstance(url, DisplayURL):
        return url
    backend = backend_for(url)
    try:
        return backend.parse_url(str(url))
    except UserInputError as exc:
        raise _bounded(exc, url) from None


def check_url(url) -> type:
    """The backend of ``url`` after its own check of the URL (:func:`parse_display_url`)."""
    return parse_display_url(url).backend


def open_display(url: str, limits=None, **options):
    """Open a display by URL: pick its backend, shake hands, keep the device alive.

    Parameters
    ----------
    url : str or DisplayURL
        ``emulator://[?...]``, ``qemu-firmware://[?...]``, ``tcs2://PORT``, a serial device path
        (``/dev/ttyUSB0``) or a pty path, or a pyserial URL; or one already parsed
        (:func:`parse_display_url`), opened without a second check.
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
        No backend for the scheme, or a malformed URL (one line, the URL bounded).
    DisplayError
        The device cannot be reached or is refused at the handshake (one line, the URL bounded).
    """
    parsed = parse_display_url(url)
    try:
        return parsed.backend.open(parsed.text, limits, **options)
    except (DisplayError, UserInputError) as exc:
        raise _bounded(exc, parsed.text)

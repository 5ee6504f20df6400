"""What every thermal display backend is: the typed :class:`Display` base and its receipts.

A backend is a subclass that names a URL scheme (``class Tcs2Display(Display, scheme="tcs2")``);
defining it registers it with :mod:`experiments.display.registry`, the only place the session,
the PsychoPy device and the command line open displays from. Each backend states what it can do
(:class:`Capabilities`) before it is opened (``thermocue displays`` lists them) and, more
precisely, once it has shaken hands with its device (:attr:`Display.capabilities`); a protocol
that needs what a backend lacks (real trials without force sensing, a profile longer than it
holds) is refused before the first trial (:mod:`experiments.session.setup`).

:class:`Display` declares everything a caller uses -- the session, the PsychoPy plugin
(``poll``, ``heartbeat``, ``is_awake``), ``thermocue displays`` (``example_urls``,
``declared_capabilities``, ``availability``) -- abstract, or with a documented default; a
backend that passes the contract test (``tests/experiments/display/test_contract.py``) works in
all of them. What a display reports is in the neutral types of :mod:`.types`. A class is a
display only by subclassing :class:`Display` (no structural check).
"""
from __future__ import annotations

import abc
import time
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Callable, ClassVar

if TYPE_CHECKING:   # the types in the signatures; importing them here would pull in numpy
    from .types import DeviceEvent, DeviceInfo, Status, Telemetry
    from .safety import SafetyLimits
    from .trial_recording import TrialRecording

__all__ = ["Capabilities", "LACKABLE", "ProfileReceipt", "Display", "EmulatedDisplay", "open_serial_port",
           "check_serial_url", "handshake_or_close"]

#: How a backend learns that the finger touched: a force threshold on the pad's sensors, or the
#: start of stimulation (a probe that rests on the skin has no force sensor).
CONTACT_DETECTION = ("force", "stimulus_start")

#: How long a port locked by another program is tried again before the open fails, s: the lock
#: of a host that has just died lasts until its heartbeat helper has exited (milliseconds).
IN_USE_WAIT_S = 1.0


#: What a display may lack of the thermocue display, and what that means (Capabilities.lacks).
LACKABLE = {
    "finger_thermometer": "no thermometer of the finger (IR)",
    "heat_sink_thermometer": "no thermometer on the heat sink",
    "stuck_sensor_rule": "no stuck-sensor rule of the device's own to latch a fault",
    "raw_setpoint": "no way to send a set-point past the host's check (the device's clamp)",
    "trip_test": "no command to lower the over-temperature trip for a test",
    "host_watchdog": "no host-silence watchdog the host can test",
    "device_clock": "no device clock (samples stamped with the host's clock on arrival)",
}


@dataclass(frozen=True)
class Capabilities:
    """What a display can do, in the units of the protocol's edges.

    Parameters
    ----------
    contact_detection : {"force", "stimulus_start"}
        ``"force"``: contact is the summed force crossing the trial's threshold (the profile's
        t = 0); ``"stimulus_start"``: the probe already rests on the skin and contact is the start
        of stimulation (by command or trigger).
    force_sensing : bool
        Whether telemetry carries the contact force (N).
    telemetry_hz : float, Hz
        Temperature readings per second during a trial.
    max_profile_points : int
        The longest profile the device holds, in samples.
    min_profile_step_s : float, s
        The shortest time step between profile samples.
    safe_range_C : tuple of float, °C
        The device's own setpoint range (its firmware or specification clamps to it).
    max_rate_C_per_s : float, °C/s
        The fastest setpoint change the device plays.
    modes : tuple of str
        ``"playback"`` (a simulated sample's profile) and/or ``"record"`` (a real sample on the
        bench, its temperature recorded).
    scripted_bench : bool
        Whether the bench is scriptable (``sim_sample``/``sim_finger``: an emulator).
    notes : str
        One line a user reads in ``thermocue displays``.
    lacks : tuple of str
        Parts of the thermocue display (docs/display-protocol.md) this device does not have at
        all, each one of :data:`LACKABLE`. ``thermocue check`` lists the checks that need one
        as not applicable to the backend, naming it; a check whose parts are declared and that
        cannot run fails. Default: nothing lacking (a plugin that says nothing is checked whole).
    """

    contact_detection: str
    force_sensing: bool
    telemetry_hz: float
    max_profile_points: int
    min_profile_step_s: float
    safe_range_C: tuple
    max_rate_C_per_s: float
    modes: tuple = ("playback", "record")
    scripted_bench: bool = False
    notes: str = ""
    lacks: tuple = ()

    def __post_init__(self):
        if not set(self.lacks) <= set(LACKABLE):
            raise ValueError(f"Capabilities.lacks: expected names among {tuple(LACKABLE)}, got "
                             f"{self.lacks!r}")
        if self.contact_detection not in CONTACT_DETECTION:
            raise ValueError(f"Capabilities.contact_detection: expected one of "
                             f"{CONTACT_DETECTION}, got {self.contact_detection!r}")
        if not set(self.modes) <= {"playback", "record"} or not self.modes:
            raise ValueError(f"Capabilities.modes: expected a non-empty subset of "
                             f"('playback', 'record'), got {self.modes!r}")

    def to_dict(self) -> dict:
        """The capabilities as JSON-ready values (for the log and ``thermocue displays``)."""
        d = asdict(self)
        d["safe_range_C"] = list(self.safe_range_C)
        d["modes"] = list(self.modes)
        d["lacks"] = list(self.lacks)
        return d


@dataclass(frozen=True)
class ProfileReceipt:
    """What a display holds after an upload, as the device confirmed it.

    Parameters
    ----------
    points : int
        Samples the device holds (for a segment-based device: the samples it was given).
    step_s : float, s
        Time step of the uploaded samples.
    crc32 : int or None
        The device's checksum of the samples, when its protocol has one.
    clamped : int
        Samples the device had to clamp to its range (a receipt with clamped > 0 is never
        returned: the upload is refused).
    max_deviation_C : float, °C
        Largest difference between what the device will play and the target: the 0.01 °C
        quantisation of the thermocue protocol, or a segment fit's error on a thermode.
    segments : int or None
        For a device that plays linear segments: how many.
    """

    points: int
    step_s: float
    crc32: int | None
    clamped: int = 0
    max_deviation_C: float = 0.0
    segments: int | None = None


class Display(abc.ABC):
    """A thermal display the session, the PsychoPy plugin and the command line run trials on.

    Subclass with ``scheme=`` to register a backend for URLs of that scheme
    (``class QemuFirmwareDisplay(ThermalDisplay, scheme="qemu-firmware")``); the registry then
    opens ``qemu-firmware://...`` with :meth:`open`. ``scheme=None`` (the default) registers
    nothing.

    Attributes
    ----------
    scheme : str
        The URL scheme the class was registered for (class attribute).
    description : str
        One line for ``thermocue displays`` (class attribute).
    url_grammar : str
        The URL grammar, for messages and ``thermocue displays`` (class attribute).
    example_urls : tuple of (str, str)
        ``(url, label)`` pairs a user can open as they are (an emulator, a simulated device);
        ``{port}`` in a URL stands for each serial port the system lists (``tcs2://{port}``).
        ``thermocue displays``, the PsychoPy plugin's device list and the contract test read
        backends from this alone (class attribute; empty: nothing to open without hardware).
    info : DeviceInfo or None
        The handshake's answer (:class:`~experiments.display.types.DeviceInfo`); None before.
    """

    scheme: ClassVar[str | None] = None
    description: ClassVar[str] = ""
    url_grammar: ClassVar[str] = ""
    example_urls: ClassVar[tuple] = ()
    info: "DeviceInfo | None" = None

    def __init_subclass__(cls, scheme: str | None = None, **kwargs):
        super().__init_subclass__(**kwargs)
        if scheme is not None:
            from .registry import register
            cls.scheme = scheme
            register(scheme, cls)

    # ------------------------------------------------------------------ opening
    @classmethod
    def open(cls, url: str, limits: "SafetyLimits | None" = None, **options) -> "Display":
        """Open ``url``, shake hands with the device and keep it alive; return the display.

        Every registered backend overrides it (the contract test checks).

        Raises
        ------
        UserInputError
            A malformed URL or option (names the option).
        DisplayError
            The device cannot be reached, or refuses the handshake (names the port and the field).
        """
        raise NotImplementedError(f"{cls.__name__}.open")

    @classmethod
    def check_url(cls, url: str) -> None:
        """Raise :class:`~experiments.errors.UserInputError` if ``url`` is malformed for this
        backend (an unknown option, a missing port), without opening anything. Default: every
        URL of the scheme is accepted here and checked when opened."""

    @classmethod
    def parse_url(cls, url: str) -> "DisplayURL":
        """``url`` checked (:meth:`check_url`) and parsed, once: a
        :class:`~experiments.display.url.DisplayURL` that opens with this backend.

        Raises
        ------
        UserInputError
            A URL this backend refuses (names the option).
        """
        from .url import DisplayURL, url_options
        cls.check_url(str(url))
        return DisplayURL(str(url), cls.scheme, cls, tuple(url_options(url).items()))

    @classmethod
    def declared_capabilities(cls) -> Capabilities:
        """What the backend can do before a device is opened (its specification)."""
        raise NotImplementedError(f"{cls.__name__}.declared_capabilities")

    @classmethod
    def availability(cls) -> tuple:
        """``(True, "")`` when the backend can be opened here, else ``(False, reason)``.
        Default: available (nothing beyond Python is needed)."""
        return True, ""

    @classmethod
    def url_availability(cls, url: str) -> tuple:
        """:meth:`availability` for one URL of the scheme (one of :attr:`example_urls`, say):
        ``(True, "")`` when that URL can be opened here. Default: the backend's availability;
        a backend whose URLs need different things (a port, or none: an emulator behind the
        same scheme) tells them apart."""
        return cls.availability()

    @property
    def capabilities(self) -> Capabilities:
        """What the opened device can do. Default: the declared capabilities (a backend whose
        handshake tells more refines them)."""
        return self.declared_capabilities()

    def check_profile_capacity(self, times_s, target_C) -> None:
        """Raise :class:`~experiments.errors.UserInputError` if the device cannot play this
        target (s, °C) as it would be uploaded; the session asks before writing its folder.
        Default: nothing beyond ``info.max_points`` and ``info.min_dt_s``, which the session
        checks itself (a device that plays samples as given)."""

    # ------------------------------------------------------------------ the engine's calls
    @abc.abstractmethod
    def set_neutral(self, temperature_C: float) -> float:
        """Hold the pad at ``temperature_C`` (°C) between trials; return what the device holds."""

    @abc.abstractmethod
    def upload_profile(self, times_s, target_C) -> ProfileReceipt:
        """Upload a target profile (s, °C), checked against the safety limits first."""

    @abc.abstractmethod
    def arm(self, mode: str = "playback", force_threshold_N: float = 2.0,
            max_duration_s: float = 20.0) -> None:
        """Arm for ``"playback"`` of the uploaded profile or ``"record"`` of a real sample."""

    @abc.abstractmethod
    def run_trial(self, timeout_s: float = 30.0,
                  on_telemetry: "Callable[[Telemetry], None] | None" = None,
                  on_event: "Callable[[DeviceEvent], None] | None" = None) -> "TrialRecording":
        """Run the armed trial to its end; each telemetry frame to ``on_telemetry``, each
        :class:`~experiments.display.types.DeviceEvent` to ``on_event``."""

    @abc.abstractmethod
    def poll(self, on_telemetry: "Callable[[Telemetry], None] | None" = None,
             on_event: "Callable[[DeviceEvent], None] | None" = None) -> bool:
        """Route what has arrived without waiting; return whether the armed trial has ended
        (False with nothing armed).

        For a caller with its own loop (PsychoPy's frame loop): call it often, then
        :meth:`run_trial` once it returns True (or after :meth:`abort`) for the recording.
        """

    @abc.abstractmethod
    def abort(self) -> None:
        """Stop whatever runs and return to neutral (the engine then sets neutral)."""

    @abc.abstractmethod
    def status(self) -> "Status":
        """The device's state now (:class:`~experiments.display.types.Status`)."""

    @abc.abstractmethod
    def heartbeat(self) -> float:
        """One acknowledged round trip; return the device's clock, s (a device without a
        clock: the host's monotonic clock). The plugin maps clocks with bursts of these."""

    def is_awake(self) -> bool:
        """Whether the device answers now; never raises. Default: one :meth:`heartbeat`,
        False on a :class:`~experiments.errors.DisplayError`."""
        from experiments.errors import DisplayError
        try:
            self.heartbeat()
            return True
        except DisplayError:
            return False

    @abc.abstractmethod
    def close(self) -> None:
        """Return to neutral (best effort) and release the port; safe to call twice."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


class EmulatedDisplay(Display):
    """A :class:`Display` that may have a scripted bench: its :attr:`~Display.info` then
    lists the capability ``"sim"`` (an emulator), and the session's stand-in hand calls these.
    A class is one only by subclassing it."""

    @abc.abstractmethod
    def sim_sample(self, material: str = "stainless_steel", roughness_m: float = 1.6e-6,
                   thickness_m: float | None = 3e-3, temperature_C: float = 20.0) -> dict:
        """Put a real sample on the emulated bench."""

    @abc.abstractmethod
    def sim_finger(self, press_after_s: float = 0.3, force_N: float = 2.0, hold_s: float = 20.0,
                   skin_thickness_m: float = 650e-6, skin_temperature_C: float = 35.5) -> dict:
        """Press the emulated finger ``press_after_s`` after arming, for ``hold_s``."""


def check_serial_url(url: str) -> None:
    """Refuse a pyserial URL that pyserial would answer with a traceback: a ``hwgrep://``
    pattern that is not a regular expression.

    Raises
    ------
    UserInputError
        One line naming the pattern's error.
    """
    import re

    from experiments.errors import UserInputError
    url = str(url)
    if url[:9].lower() == "hwgrep://":
        pattern = url[9:].split("&", 1)[0]
        try:
            re.compile(pattern, re.I)
        except re.error as exc:
            raise UserInputError(f"display: hwgrep://: expected a regular expression for the "
                                 f"port, got {pattern[:200]!r} ({exc})") from None


def open_serial_port(url: str, baudrate: int = 115200):
    """Open ``url`` with ``serial.serial_for_url`` as every serial backend does (10 ms reads).

    Raises
    ------
    UserInputError
        A pyserial URL pyserial cannot read (:func:`check_serial_url`).
    DisplayError
        The port cannot be opened (names the URL).
    """
    import serial

    from experiments.errors import DisplayError
    check_serial_url(url)
    # exclusive: a second program on the same port (another session, the PsychoPy plugin,
    # `thermocue clear-fault`) would read half of this one's replies and telemetry. A host that
    # has just died holds the lock until its heartbeat helper sees the closed pipe and exits
    # (milliseconds), so a busy port is tried again for up to IN_USE_WAIT_S.
    deadline = time.monotonic() + IN_USE_WAIT_S
    while True:
        try:
            return serial.serial_for_url(url, baudrate=baudrate, timeout=0.01,
                                         write_timeout=1.0, exclusive=True)
        except (serial.SerialException, OSError, ValueError) as exc:
            in_use = "exclusively lock" in str(exc)
            if in_use and time.monotonic() < deadline:
                time.sleep(0.05)
                continue
            if in_use:
                raise DisplayError(f"display: cannot open {url!r}: it is in use by another "
                                   f"program (another thermocue session, a PsychoPy experiment "
                                   f"or thermocue clear-fault); close that first") from exc
            raise DisplayError(f"display: cannot open {url!r}: {exc}") from exc


def handshake_or_close(display, port, on_failure=None):
    """Run ``display.handshake()``; on any failure call ``on_failure`` (if given), close
    ``port`` (best effort) and re-raise. Returns ``display``."""
    try:
        display.handshake()
    except BaseException:
        if on_failure is not None:
            on_failure()
        try:
            port.close()
        except Exception:
            pass
        raise
    return display

"""The thermal display as a PsychoPy device: ``DeviceManager.addDevice("thermocue", ...)``.

A thin :class:`psychopy.hardware.base.BaseResponseDevice` over the existing driver
(:class:`experiments.display.ThermalDisplay`): the same URLs (``/dev/ttyUSB0``, a pty path,
``emulator://...``), the same handshake, safety checks and heartbeat. Force threshold crossings
become :class:`ContactResponse` objects (contact: the summed force reached the threshold;
release: it stayed below half of it for 50 ms) carrying the device's own time stamp and its
place on PsychoPy's clock (:mod:`.clock_sync`).

Registered with PsychoPy by the ``psychopy.hardware`` entry point (``pip install
thermocue[gui]``), so ``psychopy.hardware.ThermalCueDevice`` exists once plugins are activated;
importing this module also registers the aliases ``"thermocue"`` and ``"thermalDisplay"`` with
:class:`~psychopy.hardware.manager.DeviceManager`.
"""
from __future__ import annotations

import os

from psychopy import clock as _ppclock
from psychopy import logging
from psychopy.hardware.base import BaseResponse, BaseResponseDevice

from experiments.errors import DisplayError
from experiments.display import SafetyLimits, open_display

from .clock_sync import ClockMap, SyncBurst, sync_burst
from .profiles import load_protocol_for_cue

__all__ = ["ThermalCueDevice", "ContactResponse"]


class ContactResponse(BaseResponse):
    """A force threshold crossing on the display.

    Parameters
    ----------
    t : float, s
        When it happened on PsychoPy's clock (``psychopy.clock.getTime()``'s time base), mapped
        from the device's time stamp.
    value : bool
        True for contact (force reached the threshold), False for release.
    device_time_s : float, s
        The device's own time stamp.
    force_N : float or None, N
        The summed force reported with a contact.
    kind : str
        ``"contact"`` or ``"release"``.
    """

    fields = ["t", "value", "device_time_s", "force_N", "kind"]

    def __init__(self, t, value, device_time_s=None, force_N=None, kind="contact", device=None):
        BaseResponse.__init__(self, t, value, device=device)
        self.device_time_s = device_time_s
        self.force_N = force_N
        self.kind = kind


def _same_port(a: str, b: str) -> bool:
    if "://" in a or "://" in b:
        return a == b
    return os.path.realpath(a) == os.path.realpath(b)


class ThermalCueDevice(BaseResponseDevice, aliases=["thermocue", "thermalDisplay"]):
    """The Peltier thermal display (or its emulator), for PsychoPy's DeviceManager.

    Parameters
    ----------
    url : str
        A serial device path, a pty path or ``emulator://[?...]`` (any pyserial URL).
    protocol : str, Path or Protocol, optional
        Supplies the safety limits and neutral temperature (its ``[display]`` table); without
        one, :class:`~experiments.display.SafetyLimits`' defaults (15–42 °C, 10 °C/s, 32 °C).
    baudrate : int

    Attributes
    ----------
    display : experiments.display.ThermalDisplay
        The driver (open, handshake done, heartbeat running).
    clockMap : ClockMap or None
        The latest device→PsychoPy time map (:meth:`syncClock`).
    """

    responseClass = ContactResponse

    def __init__(self, url="emulator://", protocol=None, baudrate=115200):
        BaseResponseDevice.__init__(self)
        self.url = str(url)
        self.protocol = load_protocol_for_cue(protocol) if protocol not in (None, "") else None
        if self.protocol is not None:
            from experiments.session.setup import open_session_display
            self.limits = self.protocol.display.safety_limits()
            self.display = open_session_display(self.protocol, self.url, option="url")
        else:
            self.limits = SafetyLimits()
            self.display = open_display(self.url, self.limits, baudrate=baudrate)
        self.clockMap: ClockMap | None = None
        self.firstBurst: SyncBurst | None = None
        self.lastBurst: SyncBurst | None = None
        self._ended = False

    # ------------------------------------------------------------ BaseDevice
    def isSameDevice(self, other):
        """Whether ``other`` (a device, or a dict with ``url``) is this display (same port)."""
        if isinstance(other, ThermalCueDevice):
            return other is self or _same_port(self.url, other.url)
        if isinstance(other, dict) and "url" in other:
            return _same_port(self.url, str(other["url"]))
        return False

    @staticmethod
    def getAvailableDevices():
        """Every display backend thermocue has (its display registry), and the serial ports the
        system lists now; nothing is opened or probed.

        Each backend is listed from what it states (:attr:`~experiments.display.base.Display.
        example_urls`): its examples as they are (``emulator://``, ``tcs2://emulator``,
        ``qemu-firmware://``) when it can be opened here (its ``availability``), and an example
        with ``{port}`` once per serial port (the thermocue protocol: the port's path; the TCS
        II: ``tcs2://PORT``). A backend that states no example is listed by its scheme and
        description. A port listed is only a candidate: a display is recognised when opened
        (the handshake names its firmware).
        """
        from serial.tools import list_ports

        from experiments.display.registry import backends
        cls_name = "experiments.psychopy_plugin.device.ThermalCueDevice"
        ports = [p for p in list_ports.comports() if p.hwid != "n/a"]   # n/a: a legacy UART
        profiles = []
        for backend in backends():
            scheme, about = backend.scheme, backend.description
            examples = tuple(getattr(backend, "example_urls", ()) or ())
            try:
                available = bool(backend.availability()[0])
            except Exception:        # a third-party backend's own check failing: not offered
                available = False
            listed = []
            for url, name in examples:
                if "{port}" not in url:          # an URL that needs no port of its own
                    try:
                        available = bool(backend.url_availability(url)[0])
                    except Exception:
                        available = False
                if "{port}" in url:
                    listed += [{"deviceName": name.format(port=p.device),
                                "url": url.format(port=p.device), "port": p.device,
                                "portDescription": p.description} for p in ports]
                elif available:
                    listed.append({"deviceName": name, "url": url})
            if not examples:
                listed.append({"deviceName": about or scheme, "url": f"{scheme}://"})
            profiles += [dict(p, scheme=scheme, description=about, deviceClass=cls_name)
                         for p in listed]
        order = {"emulator://": 0}
        profiles.sort(key=lambda p: order.get(p["url"], 1))    # the emulator first, as before
        return profiles

    def getDeviceProfile(self):
        info = self.display.info
        return {"deviceName": f"Thermal display {info.device_id if info else ''}".strip(),
                "url": self.url,
                "deviceClass": "experiments.psychopy_plugin.device.ThermalCueDevice"}

    def isAwake(self):
        """Whether the display answers a heartbeat (never raises)."""
        return self.display.is_awake()

    # ------------------------------------------------------------ messages
    def dispatchMessages(self):
        """Read what the display sent, without waiting; make responses of contact and release.

        Returns
        -------
        bool
            Whether the armed trial has ended (profile complete, released, maximum duration,
            aborted or a fault); False when nothing is armed.
        """
        self._ended = self.display.poll(on_event=self._onEvent) or self._ended
        return self._ended

    def _toPsychopy(self, device_s: float) -> float:
        if self.clockMap is None or self.clockMap.unmapped is not None:
            return float("nan")
        return self.clockMap.to_host(device_s)

    def _onEvent(self, ev) -> None:
        if ev.kind == "CONTACT":
            try:
                force = float(ev.text.split()[0])
            except (ValueError, IndexError):
                force = None
            self.receiveMessage(ContactResponse(self._toPsychopy(ev.device_time_s), True,
                                                ev.device_time_s, force, "contact", device=self))
        elif ev.kind == "END" and ev.reason == "released":
            self.receiveMessage(ContactResponse(self._toPsychopy(ev.device_time_s), False,
                                                ev.device_time_s, None, "release", device=self))

    def parseMessage(self, message):
        return message          # the driver parses frames; events arrive as DeviceEvent

    # ------------------------------------------------------------ clock
    def syncClock(self, duration_s: float = 0.03) -> SyncBurst:
        """Map device time to PsychoPy's clock from a burst of heartbeat round trips.

        The first call after :meth:`resetClockMap` sets the offset; later calls add the drift
        (:class:`~experiments.psychopy_plugin.clock_sync.ClockMap`). Call it with no trial
        armed (each round trip takes ~0.3 ms; the burst ``duration_s``).
        """
        burst = sync_burst(self.display.heartbeat, _ppclock.getTime, duration_s=duration_s,
                           fallback_resolution_s=1.0 / (self.display.info.telemetry_hz or 100))
        if self.firstBurst is None:
            self.firstBurst = burst
            self.clockMap = ClockMap.from_bursts(burst)
        else:
            self.lastBurst = burst
            self.clockMap = ClockMap.from_bursts(self.firstBurst, burst)
        return burst

    @staticmethod
    def clockNow() -> float:
        """PsychoPy's clock now (the time base of :meth:`toPsychopyTime`), s."""
        return _ppclock.getTime()

    def resetClockMap(self) -> None:
        """Forget the bursts (the next :meth:`syncClock` starts a new map, e.g. per trial)."""
        self.firstBurst = self.lastBurst = None

    def toPsychopyTime(self, device_s: float) -> float:
        """PsychoPy clock time (``psychopy.clock.getTime()`` base) of a device time, s."""
        return self._toPsychopy(device_s)

    # ------------------------------------------------------------ trials
    def uploadProfile(self, times_s, target_C):
        """Check against the safety limits and upload (:meth:`ThermalDisplay.upload_profile`)."""
        return self.display.upload_profile(times_s, target_C)

    def arm(self, forceThreshold_N=2.0, maxDuration_s=20.0, mode="playback"):
        """Arm a trial: the profile starts when the summed force reaches the threshold."""
        self._ended = False
        self.clearResponses()
        self.display.arm(mode=mode, force_threshold_N=forceThreshold_N,
                         max_duration_s=maxDuration_s)

    def finishTrial(self, timeout_s: float = 2.0):
        """End the armed trial (aborting it if it still runs) and return its recording.

        The display is at neutral afterwards. Returns the driver's
        :class:`~experiments.display.TrialRecording`.
        """
        if not self.dispatchMessages():
            self.display.abort()
        return self.display.run_trial(timeout_s=timeout_s)

    def neutral(self) -> bool:
        """Stop whatever runs and return the pad to neutral; never raises (for quit handlers).

        Returns
        -------
        bool
            True if the display acknowledged.
        """
        try:
            self.display.abort()
            return True
        except DisplayError as exc:
            logging.error(f"thermal display: neutral on stop failed ({exc}); the device's "
                          f"watchdog returns it to neutral within 100 ms of silence")
            return False

    def close(self):
        """Neutral, stop the heartbeat, close the port."""
        self.display.close()

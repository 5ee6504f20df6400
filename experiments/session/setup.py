"""What a session checks and opens before it writes anything.

The simulated trials' target profiles (:func:`simulated_target_profile`), computed once and
checked against the display's safe range and rate limit (:func:`check_schedule_profiles`), and
the display itself, opened so that bad input (exit 2) is told from an unreachable device (exit 1)
(:func:`open_session_display`). :mod:`experiments.session` uses and re-exports them.
"""
from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

import numpy as np

from experiments.errors import DisplayError, SessionError, UserInputError

__all__ = ["simulated_target_profile", "check_schedule_profiles", "open_session_display"]


class _Profile:
    """A target profile with the session's extra parameters (thickness source, rate limiting)."""

    def __init__(self, prof, parameters, temperature=None):
        self._prof = prof
        self.parameters = parameters
        if temperature is not None:
            self.temperature = temperature

    def __getattr__(self, name):
        return getattr(self._prof, name)

    @property
    def error_bound(self) -> float:
        """How far the uploaded profile may be from the replay it names, K: the model's own
        bound plus the most the rate limit (``rate_limit = "slew"``) changed it."""
        change = float(self.parameters.get("rate_limited_max_change_C") or 0.0)
        return float(self._prof.error_bound) + change


def simulated_target_profile(protocol, participant, group, skin_thickness_um,
                             roughness_id, roughness_um):
    """The target profile a simulated trial uploads (:func:`stimuli.target_profile`).

    Skin thickness and the sample's contact resistance come from the participant's calibration
    when it has one (:func:`experiments.calibration.calibrated_profile_parameters`: its skin
    thickness, and its fitted resistance for this sample or else Eq. 5), else from the protocol
    (the group's mean thickness or the participant's own) and Eq. 5.  The replayed side is
    ``[simulation] target_side``; the finger–pad resistance is Eq. 5 of the pad
    (``pad_roughness_um``, ``pad_material``) with the profile's skin.  With ``rate_limit =
    "slew"`` a profile faster than ``[display] max_rate_C_per_s`` is slowed to it.

    Parameters
    ----------
    protocol : Protocol
    participant : participants_schema.Participant or None
        The participant (None or an empty dict: none, e.g. a simulated study or a check).
    group : str
    skin_thickness_um : float or None, µm
        The thickness ``skin_thickness = "participant"`` simulates; None: the participant's
        measured one (:attr:`~participants_schema.Participant.measured_skin_m`).
    roughness_id : int
    roughness_um : float, µm

    Returns
    -------
    profile
        The :class:`stimuli.TargetProfile`'s attributes, with ``parameters`` extended by
        ``skin_thickness_um``, ``skin_thickness_source``, ``resistance_source`` ("calibration"
        or "eq5"), ``target_side``, ``pad_resistance_m2K_W``, ``pad_roughness_um``,
        ``pad_material``, ``rate_limited_max_change_C`` (K, 0 if unchanged).

    Raises
    ------
    SessionError
        An unusable calibration, or a compensated profile the pad cannot give (the message
        names the protocol and the field).
    """
    from experiments.calibration import CalibrationError, calibrated_profile_parameters
    from participants_schema import skin_um
    from stimuli import ModelInputError, Skin, target_profile

    sim = protocol.simulation
    where = protocol.path.name if protocol.path is not None else protocol.name
    if skin_thickness_um is None and participant:
        skin_thickness_um = skin_um(participant.measured_skin_m)
    try:
        cal = calibrated_profile_parameters(participant, roughness_id, roughness_um=roughness_um)
    except CalibrationError as exc:
        raise SessionError(str(exc)) from None
    resistance, resistance_source = None, "eq5"
    if cal is not None:
        thickness_um, source = float(cal["skin_thickness"]) * 1e6, "calibration"
        if cal.get("resistance") is not None:
            resistance, resistance_source = float(cal["resistance"]), "calibration"
    else:
        thickness_um, source = sim.skin_thickness_for(group, skin_thickness_um), "protocol"
    L = thickness_um * 1e-6
    skin = Skin(L, dermis=sim.dermis_fraction * L)
    pad_resistance = sim.pad_resistance(skin)
    try:
        prof = target_profile(material=protocol.material.name, roughness=roughness_um * 1e-6,
                              skin=skin, skin_temperature=sim.skin_temperature_C,
                              material_temperature=sim.material_temperature_C,
                              duration=sim.duration_s, rate=sim.rate_Hz, resolution=sim.resolution_C,
                              sample_thickness=(None if sim.replayed_material == "half-space"
                                                else protocol.material.thickness_m),
                              method=sim.method,
                              resistance=resistance, side=sim.target_side,
                              pad_resistance=pad_resistance)
    except ModelInputError as exc:
        raise SessionError(f"{where}: simulation.target_side: {sim.target_side!r} for sample "
                           f"{roughness_um:g} µm ({resistance_source} resistance): {exc}") from None
    params, temperature = _session_parameters(protocol, prof, thickness_um, source,
                                              resistance_source, pad_resistance)
    return _Profile(prof, params, temperature)


def _session_parameters(protocol, prof, thickness_um, source, resistance_source, pad_resistance):
    """A target profile's ``parameters`` extended by the session's (thickness source, replayed
    side, pad, rate limiting, contact model), and its temperature when the rate limit or the
    resting probe changed it (else None)."""
    sim = protocol.simulation
    params = dict(prof.parameters)
    params.setdefault("skin_thickness_um", thickness_um)
    params["skin_thickness_source"] = source
    params["resistance_source"] = resistance_source
    params["target_side"] = sim.target_side
    params["replayed_material"] = sim.replayed_material
    params["pad_resistance_m2K_W"] = pad_resistance
    params["pad_roughness_um"] = sim.pad_roughness_um
    params["pad_material"] = sim.pad_material
    temperature, change = None, 0.0
    if sim.rate_limit == "slew":
        from experiments.profile_rate import limit_rate
        window = protocol.display.safety_limits().rate_window_s   # the window the upload checks
        limited, change = limit_rate(prof.temperature, 1.0 / sim.rate_Hz, protocol.display.max_rate_C_per_s,
                                     window_s=window, resolution_C=sim.resolution_C)
        if change > 0:
            temperature = limited
            temperature.setflags(write=False)
    params["rate_limited_max_change_C"] = change
    params["contact_model"] = sim.contact_model
    if sim.contact_model == "resting":    # the probe rests on the skin: start there, ramp in
        from experiments.contact_model import resting_profile
        base = prof.temperature if temperature is None else temperature
        rested, given_up, catch_up = resting_profile(
            base, 1.0 / sim.rate_Hz, sim.skin_temperature_C, protocol.display.max_rate_C_per_s,
            window_s=protocol.display.safety_limits().rate_window_s, resolution_C=sim.resolution_C)
        rested.setflags(write=False)
        temperature = rested
        params["resting_start_C"] = float(rested[0])
        params["resting_max_change_C"] = given_up
        params["resting_catch_up_s"] = catch_up
    return params, temperature


def protocol_source(protocol) -> str:
    """How messages name a protocol: its file (a packaged one by its name), else its name."""
    from experiments.protocol import PROTOCOLS_DIR
    if protocol.path is None:
        return str(protocol.name)
    path = Path(protocol.path)
    return path.name if path.parent == PROTOCOLS_DIR else str(path)


# --------------------------------------------------------------------------- checking profiles
def _sample_label(protocol, roughness_id, roughness_um) -> str:
    try:
        return f"sample {protocol.sample(roughness_id).label}, {roughness_um:g} µm"
    except KeyError:
        return f"sample {roughness_id}, {roughness_um:g} µm"


def check_schedule_profiles(protocol, participant, group, schedule, *, source: str | None = None
                             ) -> dict:
    """Compute the target profile of every simulated trial and check it against the display's
    safe range and rate limit, before anything is written or played.

    The profiles are :func:`simulated_target_profile`'s (cached by ``stimuli.target_profile``;
    slowed to the rate limit with ``[simulation] rate_limit = "slew"``) and the check is the
    display driver's own (:func:`experiments.display.safety.check_profile` with the protocol's
    :class:`~experiments.display.safety.SafetyLimits`), so a profile that passes here passes
    the upload.

    Parameters
    ----------
    protocol : Protocol
    participant : participants_schema.Participant
    group : str
    schedule : list of TrialSpec
    source : str, optional
        How messages name the protocol (default: its file).

    Returns
    -------
    dict
        ``(roughness_id, roughness_um) -> profile``, one per simulated sample of the schedule.

    Raises
    ------
    ProtocolError
        A profile outside ``[display] min_C``-``max_C`` or faster than ``max_rate_C_per_s``, or
        a step the display cannot play: one line naming the protocol and the field to change
        (``simulation.material_temperature_C``, ``display.max_rate_C_per_s``, ...).
    SessionError
        An unusable calibration, or a compensated profile the pad cannot give.
    """
    from experiments.errors import ProtocolError, SafetyLimitError
    from experiments.display.safety import check_profile, profile_max_rate

    src = source or protocol_source(protocol)
    keys = sorted({(s.roughness_id, s.roughness_um) for s in schedule if s.mode == "simulated"})
    if not keys:
        return {}
    sim, disp = protocol.simulation, protocol.display
    limits = disp.safety_limits()
    try:
        profiles = {}
        for rid, rum in keys:
            profiles[(rid, rum)] = simulated_target_profile(protocol, participant, group, None, rid, rum)
    except UserInputError:      # SessionError: a calibration, a compensated profile the pad cannot give
        raise
    except ValueError as exc:   # limit_rate below the rounding step, a group without a thickness
        if sim.rate_limit == "slew" and "max_rate_C_per_s" in str(exc):
            raise ProtocolError(f"{src}: display.max_rate_C_per_s: expected more than "
                                f"{sim.resolution_C / limits.rate_window_s:g} °C/s with simulation."
                                f"rate_limit = 'slew' (the profile's {sim.resolution_C:g} °C steps "
                                f"over {limits.rate_window_s:g} s), got {disp.max_rate_C_per_s!r}") from None
        raise ProtocolError(f"{src}: simulation: {exc}") from None
    for (rid, rum), prof in profiles.items():
        times, temps = np.asarray(prof.times), np.asarray(prof.temperature)
        try:
            check_profile(times, temps, limits)
        except SafetyLimitError:
            lo = min(float(np.min(p.temperature)) for p in profiles.values())
            hi = max(float(np.max(p.temperature)) for p in profiles.values())
            if not (disp.min_C <= lo and hi <= disp.max_C):
                raise ProtocolError(_range_message(src, protocol, lo, hi)) from None
            dt = 1.0 / sim.rate_Hz
            rates = {k: profile_max_rate(p.temperature, dt, limits.rate_window_s)
                     for k, p in profiles.items()}
            fastest = max(rates, key=rates.get)
            rate = rates[fastest]
            raise ProtocolError(
                f"{src}: display.max_rate_C_per_s: expected at least the simulated profiles' "
                f"{rate:.3g} °C/s over {limits.rate_window_s:g} s "
                f"({_sample_label(protocol, *fastest)}), or simulation.rate_limit = 'slew', "
                f"got {disp.max_rate_C_per_s!r}") from None
        except UserInputError as exc:   # the time step: rate_Hz above the display's 1 kHz
            raise ProtocolError(f"{src}: simulation.rate_Hz: expected a rate the display can play "
                                f"({exc}), got {sim.rate_Hz!r}") from None
    return profiles


def _range_message(src, protocol, lo, hi) -> str:
    """Which field puts the simulated profiles (lo..hi °C) outside the display's range."""
    sim, disp = protocol.simulation, protocol.display
    span = f"{disp.min_C:g} ≤ T ≤ {disp.max_C:g} °C (display.min_C, display.max_C)"
    for field in ("material_temperature_C", "skin_temperature_C"):
        value = getattr(sim, field)
        if not disp.min_C <= value <= disp.max_C:
            return (f"{src}: simulation.{field}: expected a temperature whose simulated profiles "
                    f"stay within {span}, got {value!r} (the profiles span {lo:.2f} to {hi:.2f} °C)")
    field, bound = ("max_C", hi) if hi > disp.max_C else ("min_C", lo)
    return (f"{src}: display.{field}: expected a range holding the simulated profiles "
            f"({lo:.2f} to {hi:.2f} °C), got {getattr(disp, field)!r}")


def _check_backend(protocol, caps, scheme: str, source: str) -> None:
    """Refuse a display backend that cannot run the protocol's trials (before opening it).

    Real trials need the ``record`` mode (a sample on a force plate, its thermometer recorded);
    simulated trials need ``playback``.
    """
    from experiments.errors import ProtocolError
    needed = {"real": "record", "simulated": "playback"}
    for i, block in enumerate(protocol.blocks):
        mode = needed.get(getattr(block, "mode", None))
        if mode is not None and mode not in caps.modes:
            raise ProtocolError(
                f"{source}: blocks[{i}].mode: the display backend {scheme}:// cannot run "
                f"{block.mode!r} trials (it offers {', '.join(caps.modes)}); run this block on "
                f"another display, or use a protocol without it")
    sim = getattr(protocol, "simulation", None)
    if (getattr(caps, "contact_detection", None) == "stimulus_start" and sim is not None
            and sim.contact_model != "resting"
            and any(getattr(b, "mode", None) == "simulated" for b in protocol.blocks)):
        raise ProtocolError(
            f"{source}: simulation.contact_model: expected 'resting' for the display backend "
            f"{scheme}:// (its probe rests on the skin; contact is the start of stimulation), "
            f"got {sim.contact_model!r}")


def check_capacity(protocol, profiles: dict, display, source: str) -> None:
    """The profiles against an open display's capacity (``info.max_points``, ``info.min_dt_s``)."""
    from experiments.errors import ProtocolError
    caps = getattr(display, "capabilities", None)
    if caps is not None and hasattr(caps, "modes"):
        _check_backend(protocol, caps, getattr(display, "scheme", None) or "this", source)
    info = getattr(display, "info", None)
    if info is None or not profiles:
        return
    sim = protocol.simulation
    n = max(len(p.times) for p in profiles.values())
    max_points = getattr(info, "max_points", None)
    if isinstance(max_points, int) and n > max_points:
        raise ProtocolError(f"{source}: simulation.duration_s: expected a profile of at most "
                            f"{max_points} points at {sim.rate_Hz:g} Hz (the display's capacity), "
                            f"got {sim.duration_s!r} s ({n} points)")
    min_dt = getattr(info, "min_dt_s", None)
    if isinstance(min_dt, float) and 1.0 / sim.rate_Hz < min_dt * (1 - 1e-9):
        raise ProtocolError(f"{source}: simulation.rate_Hz: expected at most {1.0 / min_dt:g} Hz "
                            f"(the display's {min_dt * 1e3:g} ms step), got {sim.rate_Hz!r}")
    # a display that plays profiles its own way (a thermode's segments) says whether it can
    fits = getattr(display, "check_profile_capacity", None)
    if callable(fits):
        for key, prof in sorted(profiles.items(), key=lambda kv: str(kv[0])):
            try:
                fits(prof.times, prof.temperature)
            except UserInputError as exc:
                raise ProtocolError(f"{source}: simulation: expected profiles the display can "
                                    f"play, got sample {key[0]} ({key[1]:g} µm): {exc}") from None


# --------------------------------------------------------------------------- opening the display
def open_session_display(protocol, url: str, *, option: str = "--display", source: str | None = None):
    """Open the display for a session, telling bad input from an unreachable device.

    Parameters
    ----------
    protocol : Protocol
        Supplies the safety limits.
    url : str
        pyserial URL or device path.
    option : str
        How messages name where the URL came from (``--display``, or ``session.json``'s field).
    source : str, optional
        How messages name the protocol.

    Returns
    -------
    ThermalDisplay
        Open (handshake done); close it (``with``).

    Raises
    ------
    UserInputError
        A malformed URL or unknown emulator option, or a path that is not a serial device
        (``/dev/null``, a file): names ``option``.
    ProtocolError
        The protocol's ``[display]`` range is outside the device's own.
    DisplayError
        The device cannot be reached (no such device, busy, no answer): a runtime failure.
    """
    from experiments.errors import ProtocolError, SafetyLimitError
    from experiments.display.registry import UnknownScheme, open_display, parse_display_url, shown_url

    src = source or protocol_source(protocol)
    url = str(url)
    try:
        parsed = parse_display_url(url)         # once: the backend's own check, nothing opened
    except UnknownScheme as exc:
        raise UserInputError(f"{option}: expected a display URL or a serial device path, got "
                             f"{shown_url(url)} ({exc.expected})") from None
    except UserInputError as exc:
        raise UserInputError(f"{option}: expected a display URL, got {shown_url(url)}: "
                             f"{exc}") from None
    _check_backend(protocol, parsed.backend.declared_capabilities(), parsed.scheme, src)
    try:
        return open_display(parsed, limits=protocol.display.safety_limits())
    except SafetyLimitError as exc:
        raise ProtocolError(f"{src}: display.min_C, display.max_C: {exc.reason or exc}") from None
    except DisplayError as exc:
        cause = exc.__cause__
        if isinstance(cause, ValueError):     # pyserial: an unknown URL scheme or option
            raise UserInputError(f"{option}: expected a display URL or a serial device path, "
                                 f"got {shown_url(url)} ({cause})") from None
        if "://" not in url and cause is not None:
            if not os.path.lexists(url):
                raise DisplayError(f"display: cannot open {shown_url(url)}: no such device (is the display "
                                   f"connected and the path right?)") from None
            if not _is_terminal(url):
                raise UserInputError(f"{option}: expected a serial device (a terminal), got {shown_url(url)}, "
                                     f"which is not one") from None
            if isinstance(cause, OSError) and cause.errno in (errno.EACCES, errno.EPERM):
                raise DisplayError(f"display: cannot open {shown_url(url)}: permission denied (is the user "
                                   f"in the serial-port group, e.g. dialout?)") from None
        raise


def _is_terminal(path: str) -> bool:
    """Whether ``path`` is a terminal (a serial port or a pty); True when it cannot be told."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return True
    if not stat.S_ISCHR(mode):
        return False
    try:
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError:
        return True   # busy, no permission: the open's own reason stands
    try:
        return os.isatty(fd)
    finally:
        os.close(fd)

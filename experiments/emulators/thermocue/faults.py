"""Fault injection for the emulator: the SPEC grammar, and the byte-level faults of the link.

Grammar (also quoted in every error message)::

    SPEC := ITEM ("," ITEM)*
    ITEM := NAME ["=" VALUE] ["@" AT_s ["*"]] ["+" FOR_s]

    drop=P          each byte, either direction, is lost with probability P
    corrupt=P       each byte, either direction, gets one bit flipped with probability P
    garbage=P       per 10 ms tick, probability P of 1-32 random bytes on the line to the host
    delay=S         every chunk the device sends reaches the host S seconds late
    disconnect      the link goes dead (reads and writes fail)
    stall           the firmware hangs: no input handled, no output; its hardware watchdog
                    opens the Peltier relay
    stuck_sensor    the contact sensor's reading freezes
    sensor_range    the contact sensor reads 150 °C (open circuit)
    overtemp        the Peltier driver sticks at full heating current
    dead_relay      the Peltier relay never opens: on a fault the driver keeps the current it
                    had (a driver enabled through the relay), so the pad goes on heating
    slow_pad=F      the Peltier module gives only F (0 < F ≤ 1) of its current (a worn module,
                    a weak supply, a fan that does not cool the heat sink): the pad is slow
    late_watchdog=S the firmware's watchdog trips after S seconds of host silence, not 90 ms
    reboot          the device restarts (a power cycle, e.g. a USB brown-out) once at AT_s:
                    power-up state, no HELLO, a new boot id, device time from 0

``@AT_s`` is the device time (s) the fault starts (since power-up for a URL or command-line SPEC,
since the command for ``sim_fault``); default 0. ``+FOR_s`` is how long it lasts; default for ever.
Example: ``drop=0.001,corrupt=0.0005,overtemp@2.5``.

When a fault fires, so that a retry can succeed:

* an item **without** ``@`` is a standing condition of the device: every device opened from the
  URL has it from power-up (``drop=0.01``, ``dead_relay``);
* an item **with** ``@AT_s`` is an event that fires **once** per URL in a host process: in the
  first device opened from that ``emulator://`` URL whose clock reaches AT_s. A device opened
  again from the same URL (a session connecting again after a lost link, whose device clock
  starts again at 0) does not have it, so the retried trial can end ``ok``;
* ``@AT_s*`` fires in **every** device opened from the URL, at its AT_s (a device whose link
  drops on every connection).

The memory of fired events lives in the host process (:func:`fired_faults`); a new process (a
``thermocue resume``) starts without it. A device served on a pty (``thermocue emulator``) lives as
long as its server: a host that reconnects finds the same device, whose events have fired.
"""
from __future__ import annotations

import random
import threading
from dataclasses import dataclass

from experiments.errors import UserInputError

__all__ = ["FaultSpec", "parse_faults", "LinkFaults", "GRAMMAR", "FAULT_NAMES", "faults_for_opening",
           "note_fired", "fired_faults", "forget_fired"]

GRAMMAR = 'SPEC := NAME["="VALUE]["@"AT_s["*"]]["+"FOR_s] ("," ...)*, NAME one of ' \
          "drop, corrupt, garbage, delay, disconnect, stall, stuck_sensor, sensor_range, overtemp, " \
          "dead_relay, slow_pad, late_watchdog, reboot"

#: name -> (needs a value, value range)
FAULT_NAMES = {
    "drop": (True, (0.0, 1.0)),
    "corrupt": (True, (0.0, 1.0)),
    "garbage": (True, (0.0, 1.0)),
    "delay": (True, (0.0, 60.0)),
    "disconnect": (False, None),
    "stall": (False, None),
    "stuck_sensor": (False, None),
    "sensor_range": (False, None),
    "overtemp": (False, None),
    "dead_relay": (False, None),
    "slow_pad": (True, (0.01, 1.0)),
    "late_watchdog": (True, (0.0, 60.0)),
    "reboot": (False, None),
}
LINK_FAULTS = ("drop", "corrupt", "garbage", "delay", "disconnect")


@dataclass(frozen=True)
class FaultSpec:
    """One injected fault: ``name``, ``value`` (probability or seconds), ``at_s``, ``for_s``;
    ``once``: an ``@AT_s`` event that fires in one opening of its URL only (module docstring)."""

    name: str
    value: float | None = None
    at_s: float = 0.0
    for_s: float | None = None
    once: bool = False

    def active(self, t_s: float) -> bool:
        """Whether the fault acts at device time ``t_s``."""
        return t_s >= self.at_s and (self.for_s is None or t_s < self.at_s + self.for_s)

    def shifted(self, dt_s: float) -> "FaultSpec":
        return FaultSpec(self.name, self.value, self.at_s + dt_s, self.for_s, self.once)


#: The largest number a SPEC takes (AT_s and FOR_s: a day, s).
MAX_VALUE = 86400.0


def _number(text, item, what):
    try:
        v = float(text)
    except ValueError:
        raise UserInputError(f"faults: {item!r}: expected {what} to be a number, got {text!r} "
                             f"({GRAMMAR})") from None
    if not 0 <= v <= MAX_VALUE:                       # NaN, inf and +1e30 too: a fault that
        raise UserInputError(f"faults: {item!r}: expected 0 ≤ {what} ≤ {MAX_VALUE:g}, "
                             f"got {text!r} ({GRAMMAR})")   # would never be carried out
    return v


def parse_faults(spec: str | None, *, where: str = "faults") -> list[FaultSpec]:
    """Parse a fault SPEC (see the module docstring).

    Raises
    ------
    UserInputError
        Naming the bad item and quoting the grammar.

    Examples
    --------
    >>> parse_faults("drop=0.01,overtemp@2+1")
    [FaultSpec(name='drop', value=0.01, at_s=0.0, for_s=None, once=False), FaultSpec(name='overtemp', value=None, at_s=2.0, for_s=1.0, once=True)]
    """
    out: list[FaultSpec] = []
    if spec is None or not str(spec).strip():
        return out
    for raw in str(spec).split(","):
        item = raw.strip()
        if not item:
            continue
        rest, for_s = item, None
        if "+" in rest:
            rest, f = rest.split("+", 1)
            for_s = _number(f, item, "FOR_s")
        at_s, once = 0.0, False
        if "@" in rest:
            rest, a = rest.split("@", 1)
            once = not a.endswith("*")
            at_s = _number(a.removesuffix("*"), item, "AT_s")
        value = None
        if "=" in rest:
            rest, v = rest.split("=", 1)
            value = _number(v, item, "VALUE")
        name = rest.strip()
        if name not in FAULT_NAMES:
            raise UserInputError(f"{where}: {item!r}: expected a fault name, got {name!r} ({GRAMMAR})")
        needs, rng = FAULT_NAMES[name]
        if needs and value is None:
            raise UserInputError(f"{where}: {item!r}: expected {name}=VALUE ({GRAMMAR})")
        if not needs and value is not None:
            raise UserInputError(f"{where}: {item!r}: expected no value for {name} ({GRAMMAR})")
        if rng is not None and not (rng[0] <= value <= rng[1]):
            raise UserInputError(f"{where}: {item!r}: expected {rng[0]} ≤ VALUE ≤ {rng[1]}, "
                                 f"got {value!r} ({GRAMMAR})")
        out.append(FaultSpec(name, value, at_s, for_s, once))
    return out


# ----------------------------------------------------------------- once-events across openings
_FIRED: dict[str, set[int]] = {}      # URL -> indices (in its SPEC) of the once-events fired
_FIRED_LOCK = threading.Lock()


def faults_for_opening(key: str, specs: list[FaultSpec]) -> list[FaultSpec]:
    """The faults a device opened now from URL ``key`` gets: ``specs`` less its once-events that
    fired in an earlier opening of ``key`` in this process."""
    with _FIRED_LOCK:
        fired = _FIRED.get(key, set())
        return [s for i, s in enumerate(specs) if i not in fired]


def note_fired(key: str, specs: list[FaultSpec], t_s: float) -> None:
    """A device opened from URL ``key`` (its SPEC parsed as ``specs``) reached device time ``t_s``:
    its once-events due by then have fired and are left out of the next openings of ``key``."""
    due = {i for i, s in enumerate(specs) if s.once and s.at_s <= t_s}
    if due:
        with _FIRED_LOCK:
            _FIRED.setdefault(key, set()).update(due)


def fired_faults(key: str) -> set[int]:
    """Indices (in the SPEC of URL ``key``) of the once-events fired in this process."""
    with _FIRED_LOCK:
        return set(_FIRED.get(key, ()))


def forget_fired() -> None:
    """Forget every fired once-event (as a new host process would; the tests' fixture)."""
    with _FIRED_LOCK:
        _FIRED.clear()


class LinkFaults:
    """Byte-level faults applied by a transport to what crosses the link.

    Parameters
    ----------
    specs : list of FaultSpec
        Only the link faults among them are used.
    seed : int
    """

    def __init__(self, specs, seed: int = 0):
        self.specs = [s for s in specs if s.name in LINK_FAULTS]
        self.rng = random.Random(seed ^ 0x5EED)
        self.dropped = 0
        self.corrupted = 0

    def add(self, specs) -> None:
        self.specs += [s for s in specs if s.name in LINK_FAULTS]

    def _value(self, name, t_s):
        v = 0.0
        for s in self.specs:
            if s.name == name and s.active(t_s):
                v = max(v, s.value if s.value is not None else 1.0)
        return v

    def disconnected(self, t_s: float) -> bool:
        return any(s.name == "disconnect" and s.active(t_s) for s in self.specs)

    def delay_s(self, t_s: float) -> float:
        return self._value("delay", t_s)

    def mangle(self, data: bytes, t_s: float) -> bytes:
        """Apply drop and corrupt to ``data`` (one direction, at device time ``t_s``)."""
        if not self.specs or not data:
            return data
        p_drop, p_corrupt = self._value("drop", t_s), self._value("corrupt", t_s)
        if p_drop <= 0 and p_corrupt <= 0:
            return data
        rnd = self.rng.random
        out = bytearray()
        for b in data:
            if p_drop and rnd() < p_drop:
                self.dropped += 1
                continue
            if p_corrupt and rnd() < p_corrupt:
                b ^= 1 << self.rng.randrange(8)
                self.corrupted += 1
            out.append(b)
        return bytes(out)

    def garbage(self, t_s: float) -> bytes:
        """Random bytes to put on the line this tick (usually none)."""
        p = self._value("garbage", t_s)
        if p and self.rng.random() < p:
            return bytes(self.rng.randrange(256) for _ in range(self.rng.randint(1, 32)))
        return b""

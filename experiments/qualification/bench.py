"""What every check works with: the opened display, where plots go, how the operator is asked.

The checks use the :class:`~experiments.display.base.Display` contract (``status``,
``set_neutral``, ``upload_profile``, ``arm``, ``run_trial``, ``abort``) and, where a backend
offers them, its extras (``wait``, ``set_trip``, ``sim_finger``, ``stop_heartbeat``); a check
that needs an extra the backend lacks fails with that reason.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

__all__ = ["Bench", "Trace"]


@dataclass
class Trace:
    """Readings in time: device time (s), setpoint, contact (°C), state."""

    t_s: list = field(default_factory=list)
    setpoint_C: list = field(default_factory=list)
    contact_C: list = field(default_factory=list)
    states: list = field(default_factory=list)

    def add(self, t, sp, contact, state) -> None:
        self.t_s.append(float(t))
        self.setpoint_C.append(float(sp))
        self.contact_C.append(float(contact))
        self.states.append(state)


@dataclass
class Bench:
    """The display under test and the check's surroundings.

    Parameters
    ----------
    display : Display
        Opened through :func:`experiments.display.open_display`.
    url : str
    out : Path
        The report's folder (plots are written there).
    prompt : callable or None
        ``prompt(text) -> str`` asks the operator (None: ``--no-prompt``).
    tracking_limit_C : float, °C
        The protocol's ``[simulation] max_tracking_error_C``.
    protocol : Protocol or None
        For the paper's profiles (its simulation settings).
    profile_s : float, s
        How much of each paper profile is played (its steep start).
    weight_N : float, N
        The known weight the operator places on the pad.
    neutral_C : float, °C
    """

    display: object
    url: str
    out: Path
    prompt: Callable | None = None
    tracking_limit_C: float = 1.0
    protocol: object = None
    profile_s: float = 3.0
    weight_N: float = 4.905        # a 500 g weight
    neutral_C: float = 32.0
    log: Callable = print

    def has(self, name: str) -> bool:
        return callable(getattr(self.display, name, None))

    @property
    def scripted(self) -> bool:
        return bool(self.display.capabilities.scripted_bench)

    def virtual_clock(self):
        """The device's clock (a callable, s) when the display runs on a virtual clock (an
        emulator whose time moves only while the host waits for bytes), else None."""
        device_clock = getattr(getattr(self.display, "port", None), "device_clock", None)
        return device_clock() if callable(device_clock) else None

    def pause(self, seconds: float) -> None:
        """Let ``seconds`` pass (device time on a virtual clock), keeping the link alive."""
        if self.has("wait"):
            self.display.wait(seconds)
            return
        now = self.virtual_clock()
        if now is None:
            time.sleep(seconds)
            return
        # a virtual clock without a wait of its own (tcs2://emulator?clock=virtual): its time
        # moves only while the host waits for bytes (a sleep here left the device's time where
        # it was: the check never ended). A read of nothing waits; what arrives meanwhile is
        # the display's to read, through a status
        end = now() + seconds
        port = self.display.port
        while now() < end:
            port.read(0)
            if port.in_waiting:
                self.display.status()

    def watch(self, seconds: float, period_s: float = 0.02, trace: Trace | None = None,
              until: Callable | None = None) -> Trace:
        """STATUS every ``period_s`` for ``seconds`` of device time (or until ``until(status)``)."""
        trace = trace or Trace()
        st = self.display.status()
        t_end = st.device_time_s + seconds
        while True:
            trace.add(st.device_time_s, st.setpoint_C, st.contact_C, st.state)
            if st.device_time_s >= t_end or (until is not None and until(st)):
                return trace
            self.pause(period_s)
            st = self.display.status()

    def plot(self, name: str, title: str, t_s, series: dict, ylabel: str = "temperature (°C)",
             hlines: dict | None = None) -> str:
        """Write ``name``.png with one line per series; return the file name."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6.4, 3.2), dpi=100)
        for label, y in series.items():
            ax.plot(t_s, y, label=label, lw=1.2)
        for label, y in (hlines or {}).items():
            ax.axhline(y, ls="--", lw=0.8, color="grey")
            ax.text(t_s[0] if len(t_s) else 0, y, label, fontsize=7, va="bottom")
        ax.set_xlabel("time (s)")
        ax.set_ylabel(ylabel)
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fname = f"{name}.png"
        tmp = self.out / f".{fname}.tmp.png"
        fig.savefig(tmp)
        plt.close(fig)
        tmp.replace(self.out / fname)
        return fname


def finite(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)

"""Every temperature a TCS II reports is a safety input: the over-temperature and run-on watch.

The TCS II has no watchdog and no over-temperature latch the host can see; the host watches
what it reports. During a trial each 100 Hz line is checked (:func:`over_temperature`, by
:class:`~.trial.TcsTrial`); between trials :class:`IdleWatch` asks ``Oe`` every
:data:`IDLE_WATCH_S` on a real clock (and :meth:`~.backend.Tcs2Display.arm` asks once more on
any clock): a zone above the protocol's maximum (by more than :data:`OVER_MARGIN_C`) is
``OVER_TEMPERATURE`` at once; a stimulating zone away from the neutral temperature by more than
:data:`NEUTRAL_TOLERANCE_C` for :data:`RETURN_S` while the host expects neutral is
``STIMULATION_RUNNING``. Either is stopped at once, ``A`` then verified
(:func:`stop_and_verify`: every zone back at or below the maximum), and the trial it belongs to
(or the next one) faults with the code.

The watch thread never fights a trial for the link: it only takes the backend's I/O lock when
nobody holds it (never waiting for it) and only while no trial is armed.
"""
from __future__ import annotations

import threading

from experiments.errors import DisplayError

from . import commands as cmd
from .commands import ReplyError

__all__ = ["over_temperature", "stop_and_verify", "IdleWatch", "OVER_MARGIN_C", "IDLE_WATCH_S",
           "NEUTRAL_TOLERANCE_C", "RETURN_S", "VERIFY_S"]

#: A reading this far above the protocol's maximum is over-temperature, °C (the probe's noise
#: and its 0.1 °C resolution stay well inside it).
OVER_MARGIN_C = 0.5
#: How often the idle watch asks the temperatures, s.
IDLE_WATCH_S = 0.25
#: Off the neutral temperature by more than this ...
NEUTRAL_TOLERANCE_C = 1.0
#: ... for this long while the host expects neutral: a stimulation still running, s (the return
#: to neutral after a trial takes well under a second at the device's return speed).
RETURN_S = 3.0
#: How long ``A`` is given to bring every zone back to the maximum or below, s.
VERIFY_S = 2.0


def over_temperature(temps, max_C: float) -> str | None:
    """Which zones read above ``max_C`` (by more than the margin), as a message; or None."""
    hot = [(z, temps[z]) for z in range(1, len(temps)) if temps[z] > max_C + OVER_MARGIN_C]
    if not hot:
        return None
    return ", ".join(f"zone {z} at {t:.1f} °C" for z, t in hot) + f", above the maximum {max_C:g} °C"


def stop_and_verify(disp) -> str:
    """``A``, then read ``Oe`` until every zone is at or below the maximum; repeat ``A`` while not.

    Returns the outcome as words for the fault message (never raises).
    """
    link = disp.link
    end = link.clock() + VERIFY_S
    temps = None
    while link.clock() < end:
        try:
            disp.safe_abort()
            link.drain(0.03)
            (line,) = link.ask("Oe")
            temps = cmd.parse_temperatures(line)
        except (ReplyError, DisplayError):
            if link.lost:
                return "stopped by A; not verified (the port is gone)"
            continue
        if over_temperature(temps, disp.max_C) is None:
            return "stopped by A, verified (every zone at or below the maximum)"
        link.line(0.1)
    return "A sent; NOT verified: " + (over_temperature(temps, disp.max_C) or "no reading")


class IdleWatch:
    """The backend's watch between trials: a daemon thread asking ``check`` every period."""

    def __init__(self, disp, period_s: float = IDLE_WATCH_S):
        self.disp = disp
        self.period_s = period_s
        self._stop = threading.Event()
        self._th = threading.Thread(target=self._run, name="tcs2-idle-watch", daemon=True)
        self._th.start()

    def _run(self) -> None:
        d = self.disp
        while not self._stop.wait(self.period_s):
            if not d._io.acquire(blocking=False):
                continue                      # a command or a trial is using the link
            try:
                if d._trial is None and not d.link.lost and d.port.is_open:
                    d.check_idle()
            except Exception:                 # the next command in the main thread says why
                pass
            finally:
                d._io.release()

    def stop(self) -> None:
        self._stop.set()
        if self._th is not threading.current_thread():
            self._th.join(2.0)

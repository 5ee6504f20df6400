"""How a run ends early, and a trial that is given up: :class:`RunStops`.

A session (:class:`~experiments.session.Session`) holds one (``session.stops``). After an attempt
the run asks it, in this order: a trial out of ``[contact] max_attempts`` is given up
(:meth:`RunStops.give_up`); a fault no re-run cures stops the run (:meth:`RunStops.after_fatal`);
a lost link is connected once more (:meth:`RunStops.reconnect`) or stops it
(:meth:`RunStops.after_link_lost`); ``max_consecutive_faults`` faults in a row stop it
(:meth:`RunStops.after_faults`). Every stop is resumable; the display is put to neutral first
where it can still be reached.
"""
from __future__ import annotations

import re

from experiments.errors import DisplayError, UserInputError
from experiments.session.store import record_display

__all__ = ["RunStops"]


def _bare(message: str) -> str:
    """A display error's text without its leading ``display:`` (one clean message)."""
    text = re.sub(r"^(\s*display:\s*)+", "", str(message), flags=re.IGNORECASE).strip()
    return re.sub(r"^link lost\s*", "", text).strip(" :") or text


class RunStops:
    """The early ends of a :class:`~experiments.session.Session`'s run.

    Parameters
    ----------
    session : Session
        Whose log, display, state machine and fault state (``_fatal``, ``_link_lost``,
        ``_given_up``, ``_lost_because``) the stops use.
    """

    def __init__(self, session):
        self.session = session

    def reconnect(self, disp, trial_index: int):
        """The display's port failed: close it and open it once more.

        Returns the display opened again (its handshake done, neutral set, logged as
        ``display_reconnected``), or None if that failed too (logged as ``display_error``).
        """
        code, message = self.session._link_lost
        self.session._link_lost = None
        try:
            disp.close()
        except Exception:
            pass
        if self.session.display_url is None:
            self.session._lost_because = (message, "no display URL to open again")
            return None
        try:
            again = self.session._open_display()
        except DisplayError as exc:
            if isinstance(exc, UserInputError):
                raise
            self.session.log_event("display_error", step="reconnect", message=str(exc))
            self.session._lost_because = (message, str(exc))
            return None
        self.session._reopened.append(again)
        self.session.display = again
        info = getattr(again, "info", None)
        self.session.log_event("display_reconnected", url=self.session.display_url, trial_index=trial_index,
                       device_id=getattr(info, "device_id", None),
                       image_id=getattr(info, "image_id", "") or "")
        record_display(self.session.directory, self.session.display_url, info, durable=self.session.durable)
        again.set_neutral(self.session.protocol.display.neutral_C)
        self.session._report(f"trial {trial_index}: the display's link was lost ({_bare(message)}); "
                     f"connected again, the trial runs again")
        return again

    def give_up(self, trial_index: int, attempts: int) -> None:
        """Log that a trial reached ``[contact] max_attempts`` attempts in this run without an
        ``ok`` one (a resume after a stop runs it again, with as many attempts)."""
        limit = self.session.protocol.contact.max_attempts
        self.session._given_up.add(trial_index)
        self.session.log_event("trial_given_up", trial_index=trial_index, attempts=attempts,
                       max_attempts=limit)
        self.session._report(f"trial {trial_index}: given up after {attempts} attempts without a "
                     f"clean one (the protocol's [contact] max_attempts = {limit}); the session "
                     f"goes on without it")

    def n_completed(self, queue) -> int:
        """Trials with an ``ok`` attempt: neither still to run nor given up."""
        return self.session.n_trials - len(queue) - len(self.session._given_up)

    def after_faults(self, disp, faults: int, queue) -> int:
        """Stop after ``max_consecutive_faults`` faulted attempts in a row (resumable)."""
        self.session.machine.go("idle")
        self.session.machine.go("stopped")
        self.session._neutral(disp)
        self.session.log_event("session_stopped", reason=f"{faults} consecutive faults",
                       n_completed=self.n_completed(queue))
        self.session._report(f"stopped after {faults} consecutive faults; resume with "
                     f"`thermocue resume {self.session.directory}`")
        return 1

    def after_link_lost(self, queue) -> int:
        """Stop after a lost link that one reconnect did not cure (resumable once fixed)."""
        lost, why = self.session._lost_because
        self.session.machine.go("idle")
        self.session.machine.go("stopped")
        self.session.log_event("session_stopped", reason="display link lost", message=lost,
                       reconnect=why, n_completed=self.n_completed(queue))
        self.session._report(f"stopped: the display's link was lost ({_bare(lost)}) and connecting "
                     f"again failed ({_bare(why)}); check its cable and power, then resume with "
                     f"`thermocue resume {self.session.directory}`")
        return 1

    def after_fatal(self, disp, queue) -> int:
        """Stop the session after a fault that no re-run can cure (resumable once fixed)."""
        code, message = self.session._fatal
        self.session.machine.go("idle")
        self.session.machine.go("stopped")
        self.session._neutral(disp)
        advice = "the display restarted: resume to shake hands with it again"
        self.session.log_event("session_stopped", reason=f"display fault {code}", message=message,
                       n_completed=self.n_completed(queue))
        self.session._report(f"stopped: {advice} (`thermocue resume {self.session.directory}`)")
        return 1

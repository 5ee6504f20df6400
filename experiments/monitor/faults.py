"""What a fault code means, in words for the experimenter (the codes of docs/display-protocol.md
§7 and the host's and the session's own)."""
from __future__ import annotations

__all__ = ["FAULT_WORDS", "explain"]

FAULT_WORDS = {
    "WATCHDOG": "the display heard nothing from the computer for 90 ms (host heartbeat lost) and "
                "took the pad to neutral on its own; the trial is run again",
    "OVER_TEMPERATURE": "the pad read above 44.8 °C (or the heat sink above 70 °C): the display "
                        "cut the Peltier current; the fault stays until an operator resets it "
                        "(thermocue clear-fault)",
    "SENSOR_FAILURE": "the contact thermometer read outside -10…90 °C (open or short circuit): "
                      "the Peltier relay was opened; it stays until an operator resets it",
    "SENSOR_STUCK": "the contact thermometer gave 20 identical readings in a row (a dead "
                    "sensor): the relay was opened; it stays until an operator resets it",
    "FAULT_LATCHED": "the display refused to arm: an earlier fault is latched until an operator "
                     "resets it (thermocue clear-fault)",
    "BAD_STATE": "the display refused the command in the state it was in (after a latched "
                 "fault it refuses every trial until an operator resets it)",
    "LINK_TIMEOUT": "the display did not answer after the retries",
    "LINK_LOST": "the display's port failed (unplugged cable, powered off); its watchdog takes "
                 "the pad to neutral",
    "TRIAL_TIMEOUT": "the trial did not end in time",
    "TELEMETRY_LOSS": "more than 1 % of the display's telemetry frames were lost",
    "NOT_DELIVERED": "the display did not deliver the trial (no contact, or an end other than "
                     "complete, release or the maximum duration)",
    "DEVICE_RESTARTED": "the display restarted (new boot id, its clock went back, or it asked "
                        "for a new handshake): the session stops; resume it",
    "TRACKING_ERROR": "the pad was further from its target than the protocol allows "
                      "([simulation] max_tracking_error_C); the trial is run again",
    "no_contact": "nobody touched the pad within the time-out; the trial is run again",
    "killed": "the session process ended during this attempt (a kill or a power cut)",
    "interrupted": "the session was interrupted (Ctrl-C or SIGTERM) during this attempt",
}


def explain(code) -> str:
    """The words for a fault code (or an abort reason); the code itself when unknown."""
    if code is None or code == "":
        return ""
    return FAULT_WORDS.get(str(code), f"display fault {code}")

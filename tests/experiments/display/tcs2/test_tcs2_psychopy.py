"""The PsychoPy device runs a trial on tcs2:// unchanged (it opens displays through the registry)."""
from __future__ import annotations

import numpy as np

from experiments.psychopy_plugin.device import ThermalCueDevice

T = np.arange(0, 3.0001, 0.01)
PROFILE = np.round(np.interp(T, [0, 1, 3], [32.0, 29.0, 29.5]), 2)


def test_a_trial_through_the_psychopy_device():
    dev = ThermalCueDevice("tcs2://emulator?clock=virtual")
    try:
        assert dev.isAwake()
        assert dev.getDeviceProfile()["deviceName"].startswith("Thermal display EM")
        dev.syncClock(duration_s=0.01)
        receipt = dev.uploadProfile(T, PROFILE)
        assert receipt.segments == 2 and receipt.max_deviation_C <= 0.1 + 1e-9
        dev.arm()
        for _ in range(100000):
            if dev.dispatchMessages():
                break
        rec = dev.finishTrial()
        assert rec.status == "ok" and rec.end_reason == "complete" and rec.frames == 300
        contacts = [r for r in dev.responses if r.value]
        assert len(contacts) == 1 and contacts[0].device_time_s == rec.contact_time_s
        assert dev.neutral()
    finally:
        dev.close()

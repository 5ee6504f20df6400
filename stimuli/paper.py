"""The paper's constants and the names built on them, in one place.

Standard library only (no numpy): the command line reads its ``choices=`` from here. Every module
that needs one of these numbers or names imports it from here instead of writing it again.

Sources are the paper's sections and tables (/work/shared/seed: §3.1 samples, §3.2 cohort and
display, Table 2, Table 3).
"""
from __future__ import annotations

__all__ = [
    "SAMPLE_NAMES", "SAMPLE_ROUGHNESS_UM", "TABLE2_ROUGHNESS_UM", "SAMPLE_MATERIAL",
    "PAD_ROUGHNESS_UM", "PAD_ROUGHNESS_M", "PAD_MATERIAL", "TARGET_SIDES", "REPLAY_NAMES", "RATE_LIMITS",
    "GROUP_THICKNESS_UM", "GROUP_TARGET_THICKNESS_UM", "SKIN_TEMPERATURE_RANGE_C",
    "TARGET_SKIN_TEMPERATURE_C", "DERMIS_FRACTION_RANGE", "RESPONDER_NAMES", "MODES",
]

#: Table 3: the four steel samples 1#..4#, in this order.
SAMPLE_NAMES = ("1#", "2#", "3#", "4#")
#: Table 3: their roughness R_a, µm.
SAMPLE_ROUGHNESS_UM = (1.6, 12.5, 50.0, 100.0)
#: Table 2 (Experiment 1) adds the 0.4 µm sample before them, µm.
TABLE2_ROUGHNESS_UM = (0.4,) + SAMPLE_ROUGHNESS_UM
#: §3.1: the samples are stainless steel (a :func:`stimuli.material` name).
SAMPLE_MATERIAL = "stainless_steel"

#: The display's contact face: polished copper, R_a 0.4 µm (``[simulation] pad_roughness_um`` and
#: ``pad_material`` defaults; the emulated pad's finger–pad resistance).
PAD_ROUGHNESS_UM = 0.4
PAD_ROUGHNESS_M = PAD_ROUGHNESS_UM * 1e-6
PAD_MATERIAL = "copper"

#: What a display can replay (``stimuli.target_profile(side=...)``, ``[simulation] target_side``):
#: the material side of the interface (the printed Eq. 7), its skin side, or the pad temperature
#: compensated for the finger–pad contact resistance.
TARGET_SIDES = ("material", "skin", "compensated")
#: The replay hypotheses (what the paper's display played, ``reproduce figure9 --replay``), named
#: by what is played: printed Eq. 7 (material side, half-space), the exact material side of a
#: half-space and of the 3 mm slab, the exact skin side, the compensated pad temperature.
REPLAY_NAMES = ("printed", "halfspace", "slab", "skin", "compensated")
#: ``[simulation] rate_limit``: refuse a profile faster than the display, or slew it.
RATE_LIMITS = ("refuse", "slew")
#: The two kinds of trial: the real samples, or the display simulating them.
MODES = ("real", "simulated")

#: §3.2: the groups' fingertip skin thickness ranges, µm.
GROUP_THICKNESS_UM = {"A": (600.0, 750.0), "B": (900.0, 1200.0)}
#: §3.2: the skin thickness each group's simulated profiles are computed for, µm.
GROUP_TARGET_THICKNESS_UM = {"A": 650.0, "B": 1000.0}
#: §3.2: the participants' skin temperature, °C.
SKIN_TEMPERATURE_RANGE_C = (35.5, 36.0)
#: Skin temperature the protocol's target profiles are computed for, °C
#: (``roughness_recognition.toml``, ``[simulation] skin_temperature_C``).
TARGET_SKIN_TEMPERATURE_C = 35.5
#: The dermis' share of the total skin thickness the simulated participants are drawn from.
DERMIS_FRACTION_RANGE = (0.55, 0.65)

#: Who answers the trials (``--responder``; the names the responder classes register): a
#: participant on the PsychoPy window, the experimenter keying spoken answers on the console, or
#: the simulated participant.
RESPONDER_NAMES = ("psychopy", "console", "simulated")

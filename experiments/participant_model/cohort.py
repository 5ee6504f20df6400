"""The paper's cohort of 30 simulated participants, as participant records.

§3.2 of the paper: thirty right-handed adults aged 18-45 (twelve women, eighteen men) of
different occupations, split by fingertip skin thickness into group A (600-750 µm: five men,
ten women) and group B (900-1200 µm: twelve men, three women). :func:`paper_cohort` writes such
a cohort as participant records (valid against ``participants_schema``); the thicknesses,
dermis shares, skin temperatures and ages are drawn uniformly within the stated ranges from a
seed. :mod:`.figure9` runs them through the Figure 9 study.

The paper contradicts itself on the sexes: "twelve women and eighteen men", but group A "has
five men and ten women" and group B "twelve men and three women", i.e. 13 women and 17 men.
The cohort follows the per-group numbers (they fix who is in which group); both are 15 per
group, which is what the analysis compares.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from participants_schema import validate_participant
from stimuli.paper import DERMIS_FRACTION_RANGE, GROUP_THICKNESS_UM, SKIN_TEMPERATURE_RANGE_C

__all__ = ["PAPER_GROUPS", "CohortGroup", "paper_cohort", "write_cohort", "alternate_groups"]


@dataclass(frozen=True)
class CohortGroup:
    """One group of the paper's cohort.

    Parameters
    ----------
    name : str
    men, women : int
    thickness_um : (float, float), µm
        Range of the total fingertip skin thickness.
    """

    name: str
    men: int
    women: int
    thickness_um: tuple[float, float]


#: §3.2: A = 5 men + 10 women, 600-750 µm; B = 12 men + 3 women, 900-1200 µm.
PAPER_GROUPS = (CohortGroup("A", 5, 10, GROUP_THICKNESS_UM["A"]),
                CohortGroup("B", 12, 3, GROUP_THICKNESS_UM["B"]))
#: "different occupations, for example, student, teacher, worker, farmer, etc."
OCCUPATIONS = ("student", "teacher", "worker", "farmer", "engineer", "nurse", "clerk", "driver")
AGE_RANGE = (18, 45)


def paper_cohort(seed: int = 0, groups=PAPER_GROUPS) -> list[dict]:
    """Participant records of the paper's cohort (P01..P30), reproducible from ``seed``.

    Parameters
    ----------
    seed : int
    groups : sequence of CohortGroup

    Returns
    -------
    list of dict
        Records valid for :func:`participants_schema.validate_participant`; each has an
        ``x_simulation`` member with the intended group and the draw's seed.
    """
    rng = np.random.default_rng([int(seed), 0xC0_40_27])
    records = []
    n = 0
    for group in groups:
        sexes = ["male"] * group.men + ["female"] * group.women
        rng.shuffle(sexes)
        for sex in sexes:
            n += 1
            total = round(float(rng.uniform(*group.thickness_um)), 1)
            dermis = round(total * float(rng.uniform(*DERMIS_FRACTION_RANGE)), 1)
            records.append({
                "schema_version": 1,
                "id": f"P{n:02d}",
                "age": int(rng.integers(AGE_RANGE[0], AGE_RANGE[1] + 1)),
                "sex": sex,
                "handedness": "right",
                "dominant_hand": "right",
                "occupation": str(rng.choice(OCCUPATIONS)),
                "skin_thickness": {
                    "epidermis_um": round(total - dermis, 1),
                    "dermis_um": dermis,
                    "total_um": total,
                    "method": "simulated: uniform within the paper's group range (§3.2)",
                    "finger": "right index",
                },
                "initial_skin_temperature_C": round(float(rng.uniform(*SKIN_TEMPERATURE_RANGE_C)), 2),
                "consent": {"given": True, "date": "2026-01-01", "form": "simulated participant"},
                # the module's old name, kept: the records (and the study's outputs) stay
                # byte-identical
                "notes": "Simulated participant of the Figure 9 study (experiments.cohort).",
                "x_simulation": {"group": group.name, "seed": int(seed) * 1000 + n},
            })
    return records


def write_cohort(directory, seed: int = 0) -> list[Path]:
    """Write :func:`paper_cohort` as ``<directory>/<id>.json`` (validated); return the paths."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for record in paper_cohort(seed):
        path = directory / f"{record['id']}.json"
        validate_participant(record, source=str(path))
        path.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
        paths.append(path)
    return paths


def alternate_groups(records, n: int) -> list:
    """The first ``n`` records taking the groups in turn (A, B, A, B, ...), ids unchanged.

    Parameters
    ----------
    records : sequence of dict
        Participant records in cohort order (:func:`paper_cohort`: P01-P15 group A, P16-P30
        group B); the group is ``x_simulation.group``.
    n : int
        How many to take, 1 to ``len(records)``.

    Returns
    -------
    list of dict
        Group A's first, group B's first, A's second, ...: any ``n >= 2`` compares both groups
        (sizes differing by at most one while both last), and ``n = len(records)`` is every
        record, in the same interleaved order.
    """
    queues: dict = {}
    for record in records:
        extra = record.get("x_simulation")
        group = extra.get("group") if isinstance(extra, dict) else None
        queues.setdefault(group, []).append(record)
    queues = [list(q) for q in queues.values()]
    out = []
    while len(out) < n and any(queues):
        for queue in queues:
            if queue and len(out) < n:
                out.append(queue.pop(0))
    return out

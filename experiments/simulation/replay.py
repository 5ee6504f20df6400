"""Replay hypotheses: what the display played on the paper's simulated trials, as protocol variants.

The paper says its simulated cues were "reproduced from the Equation (7)" (§3.2), the material
side of the finger–sample interface.  Its own Table 2 "simulation" column rises with roughness
(25.70 → 28.82 °C), which Eq. 7 cannot do (it falls as the contact resistance grows), so what
was computed and played is uncertain.  Each hypothesis is named by what the display plays: the
formula, the side of the interface and the material it is computed for.  Each is a documented
variant of a protocol, built from the protocol's data (:attr:`Protocol.data`) with
:func:`experiments.protocol.parse_protocol`, never by editing TOML text.

=============  ====================================================================================
name           what the display replays (``[simulation]`` method, side, material)
=============  ====================================================================================
printed        Eq. 7 exactly as printed (its n = 0 term with the printed e_MR): material side
               T_M(L+), steel half-space (the closed forms have no back face);
               ``method = "paper-as-printed"``
halfspace      the exact material side T_M(L+) for a steel half-space (numerical inversion of the
               exact Laplace solution; what Eq. 7 approximates)
slab           the exact material side T_M(L+) for the protocol's 3 mm steel slab, insulated back
               (the sample the participants touched)
skin           the exact skin side T_S(L-) of the same 3 mm slab contact: the trend of Table 2's
               column (needs ``rate_limit = "slew"``: it starts with a jump from the skin)
compensated    the pad temperature that, through the finger–pad contact resistance, gives the skin
               the real 3 mm slab contact's history (needs ``rate_limit = "slew"``: 3# and 4# start
               faster than the display's 10 °C/s)
=============  ====================================================================================

Why the printed form and not the corrected one: the hypothesis is "the display played what the
paper printed"; the corrected closed form (all image terms, the misprints of
:mod:`stimuli.paper_forms` fixed) is within 0.8 K of the exact half-space at 20 s and is covered
by ``halfspace``.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass

__all__ = ["ReplayHypothesis", "REPLAY_HYPOTHESES", "replay_hypothesis", "protocol_variant",
           "with_display_familiarisation"]


@dataclass(frozen=True)
class ReplayHypothesis:
    """One hypothesis about what the paper's display replayed.

    Parameters
    ----------
    name : str
        Short name (``--replay`` option, scenario rows).
    target_side : {"material", "skin", "compensated"}
        ``[simulation] target_side`` of the variant.
    rate_limit : {"refuse", "slew"}
        ``[simulation] rate_limit`` of the variant.
    method : {"exact", "paper-as-printed"}
        ``[simulation] method`` of the variant (:class:`stimuli.Contact` method).
    replayed_material : {"sample", "half-space"}
        ``[simulation] replayed_material`` of the variant.
    label : str
        One line for tables and figure titles.
    profile_model : str
        The formula the played profile is computed with (claims tables name it).
    reason : str
        Why the hypothesis is considered (its source in the paper).
    """

    name: str
    target_side: str
    rate_limit: str
    method: str
    replayed_material: str
    label: str
    profile_model: str
    reason: str


#: The five hypotheses, by name, in the order tables show them.
REPLAY_HYPOTHESES = {
    "printed": ReplayHypothesis(
        "printed", "material", "refuse", "paper-as-printed", "half-space",
        "printed Eq. 7 (material side)",
        "Eq. 7 as printed (n = 0 term, printed e_MR), material side T_M(L+), steel half-space",
        "§3.2: 'the theoretical thermal cues are reproduced from the Equation (7)'"),
    "halfspace": ReplayHypothesis(
        "halfspace", "material", "refuse", "exact", "half-space",
        "exact material side, half-space",
        "exact Laplace solution, material side T_M(L+), steel half-space",
        "what Eq. 7 approximates: the same side and material without the closed form's "
        "truncation and misprints"),
    "slab": ReplayHypothesis(
        "slab", "material", "refuse", "exact", "sample",
        "exact material side, 3 mm slab",
        "exact Laplace solution, material side T_M(L+), 3 mm steel slab with insulated back",
        "Eq. 7's side computed for the samples' real 3 mm thickness (§3.1)"),
    "skin": ReplayHypothesis(
        "skin", "skin", "slew", "exact", "sample",
        "exact skin side, 3 mm slab",
        "exact Laplace solution, skin side T_S(L-), 3 mm steel slab with insulated back",
        "Table 2's simulation column rises with roughness (25.70 -> 28.82 °C) as the skin side "
        "does, while Eq. 7 falls"),
    "compensated": ReplayHypothesis(
        "compensated", "compensated", "slew", "exact", "sample",
        "compensated (real contact at the skin)",
        "T_S(L-) - (R_pad / R)(T_S(L-) - T_M(L+)), exact sides, 3 mm steel slab",
        "§3.2: 'the temperature drop loss is compensated according to our thermal model'; "
        "a display that reproduces the real contact through its own contact resistance"),
}


def replay_hypothesis(name: str) -> ReplayHypothesis:
    """The hypothesis called ``name``.

    Raises
    ------
    experiments.errors.UserInputError
        Unknown name (the message lists the known ones).
    """
    from experiments.errors import UserInputError
    try:
        return REPLAY_HYPOTHESES[name]
    except KeyError:
        raise UserInputError(f"--replay: expected one of {', '.join(REPLAY_HYPOTHESES)}, "
                             f"got {name!r}") from None


def _with_simulation(data: dict, **changes) -> dict:
    data = copy.deepcopy(dict(data))
    sim = dict(data.get("simulation") or {})
    sim.update(changes)
    data["simulation"] = sim
    return data


def protocol_variant(protocol, hypothesis, *, display_familiarisation: bool = False):
    """``protocol`` with its simulated trials replaying ``hypothesis``.

    Parameters
    ----------
    protocol : Protocol or str
        A loaded protocol or a name/path for :func:`experiments.protocol.load_protocol`.
    hypothesis : ReplayHypothesis or str
    display_familiarisation : bool
        Also familiarise on the display (:func:`with_display_familiarisation`), for the
        ``display_learned`` observer.

    Returns
    -------
    Protocol
        Parsed from a modified copy of ``protocol.data`` (:func:`parse_protocol`), so every
        check of the protocol applies; its ``hash`` differs from the original's whenever a
        value changed, and ``path`` is None (the variant has no file).

    Raises
    ------
    experiments.errors.UserInputError
        Unknown hypothesis, or a protocol without a ``[simulation]`` table.
    """
    from experiments.errors import UserInputError
    from experiments.protocol import load_protocol, parse_protocol
    if isinstance(hypothesis, str):
        hypothesis = replay_hypothesis(hypothesis)
    if not hasattr(protocol, "data"):
        protocol = load_protocol(protocol)
    if protocol.simulation is None:
        raise UserInputError(f"{protocol.name}: simulation: expected a [simulation] table for a "
                             f"replay hypothesis, got nothing")
    wanted = {"target_side": hypothesis.target_side, "rate_limit": hypothesis.rate_limit,
              "method": hypothesis.method, "replayed_material": hypothesis.replayed_material}
    # only what differs: a hypothesis that is the protocol as written keeps its content and hash
    data = _with_simulation(protocol.data, **{k: v for k, v in wanted.items()
                                              if getattr(protocol.simulation, k) != v})
    if display_familiarisation:
        data = _add_display_familiarisation(data)
    source = f"{protocol.name} (replay: {hypothesis.name}" + \
        (", familiarised on the display)" if display_familiarisation else ")")
    return parse_protocol(data, source=source, path=None)


#: Name of the block :func:`with_display_familiarisation` adds.
DISPLAY_FAMILIARISATION_BLOCK = "familiarise_display"


def _add_display_familiarisation(data: dict) -> dict:
    data = copy.deepcopy(dict(data))
    blocks = [dict(b) for b in data.get("blocks", [])]
    if any(b.get("name") == DISPLAY_FAMILIARISATION_BLOCK for b in blocks):
        return data
    first_sim = next((i for i, b in enumerate(blocks) if b.get("mode") == "simulated"), len(blocks))
    template = next((b for b in blocks if str(b.get("name", "")).startswith("familiar")), None)
    block = {"name": DISPLAY_FAMILIARISATION_BLOCK, "mode": "simulated", "repetitions":
             int(template.get("repetitions", 1)) if template else 1, "order": "fixed",
             # the participant repeats the named sample's number (unscored): the simulated
             # responder perceives a trial, and learns from it, only when asked to answer
             "scored": False, "feedback": True, "response": True,
             "instructions": "Each sample is named before the display plays it: remember how it "
                             "feels."}
    blocks.insert(first_sim, block)
    data["blocks"] = blocks
    return data


def with_display_familiarisation(protocol):
    """``protocol`` with a familiarisation block on the display before its first simulated block.

    The block (``familiarise_display``: mode simulated, unscored, named samples; the participant
    repeats the number, so that the simulated responder feels and learns each one) has
    as many repetitions as the protocol's own familiarisation block.  The paper familiarised on
    the real samples only; this variant is the ``display_learned`` observer's protocol.
    """
    from experiments.protocol import load_protocol, parse_protocol
    if not hasattr(protocol, "data"):
        protocol = load_protocol(protocol)
    return parse_protocol(_add_display_familiarisation(protocol.data),
                          source=f"{protocol.name} (familiarised on the display)", path=None)

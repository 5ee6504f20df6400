"""What the claims table says, in words: the verdict line, the claims screen, and what decides them.

Every claim probability carries its Monte Carlo interval (:mod:`.precision`): a claim is shown
(✓), not shown (✗) or undecided at this precision (?) by a scenario, and a scenario reproduces
the paper's claims, does not, or is undecided (:func:`.precision.scenario_status`).  The
verdict line states both readings on every claim, then the result on the paper's own claims
alone (without the project's ``*`` criteria), naming the ``*`` claim and the assumption that
decide the difference, and a response bias in words.
"""
from __future__ import annotations

import numpy as np

from .precision import MARK, MC_LEVEL, THRESHOLD, claim_status, interval_text, scenario_status

__all__ = ["claims_screen", "verdict_line", "claims_held", "reproducing_scenarios",
           "scenario_statuses", "claim_statuses", "paper_claims_sentence", "bias_text",
           "PRINTED", "READING_TEXT"]

#: The paper's method as printed: Eq. 7's material side as printed (half-space), judged as the
#: project's original absolute observer did.
PRINTED = ("printed", "absolute")

#: How each reading is named in lines and tables.
READING_TEXT = {"descriptive": "read descriptively (the direction the paper states, in a "
                               "study's point estimates)",
                "inferential": "read inferentially (each direction with its one-sided test "
                               "at 0.05)"}

_LEVEL = f"{MC_LEVEL * 100:g} %"


def _claims(wide, paper_only: bool = False):
    from analysis.claims import CLAIMS
    return [c for c in CLAIMS if c.id in wide.columns and not (paper_only and c.own)]


def claim_statuses(result, scenario, reading: str = "descriptive",
                   paper_only: bool = False) -> dict:
    """claim id -> (status, probability, low, high) of one scenario."""
    key = ("claim_statuses", reading)
    if key not in result.cache:
        wide = result.wide(reading)
        low, high = result.bounds(reading)
        claims = _claims(wide)
        result.cache[key] = {
            k: {c.id: (claim_status(lo[c.id], hi[c.id]), p[c.id], lo[c.id], hi[c.id])
                for c in claims}
            for k, p, lo, hi in zip(wide.index, wide.to_dict("records"),
                                    low.loc[wide.index].to_dict("records"),
                                    high.loc[wide.index].to_dict("records"))}
    own = {c.id for c in _claims(result.wide(reading)) if c.own}
    return {cid: v for cid, v in result.cache[key][tuple(scenario)].items()
            if not (paper_only and cid in own)}


def scenario_statuses(result, reading: str = "descriptive", paper_only: bool = False) -> dict:
    """scenario -> "reproduced" / "not reproduced" / "undecided"."""
    return {k: scenario_status(s for s, *_ in claim_statuses(result, k, reading, paper_only).values())
            for k in result.wide(reading).index}


def claims_held(result, scenario, reading: str = "descriptive",
                paper_only: bool = False) -> tuple[int, int]:
    """``(claims shown: interval above 0.5, claims)`` of one scenario."""
    st = claim_statuses(result, scenario, reading, paper_only)
    return sum(s == "shown" for s, *_ in st.values()), len(st)


def reproducing_scenarios(result, reading: str = "descriptive", paper_only: bool = False) -> list:
    """Scenarios in which every claim's interval lies above 0.5."""
    return [k for k, s in scenario_statuses(result, reading, paper_only).items() if s == "reproduced"]


def _name(scenario) -> str:
    return f"{scenario[0]}/{scenario[1]}"


def _label(scenario) -> str:
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    return f"the {REPLAY_HYPOTHESES[scenario[0]].label} replay with the {scenario[1]} observer"


def _short(cid: str) -> str:
    from analysis.claims import CLAIMS
    c = next(c for c in CLAIMS if c.id == cid)
    return c.short + ("*" if c.own else "")


def _list(st: dict, status: str) -> str:
    return ", ".join(f"{_short(cid)} {interval_text(p, lo, hi)}"
                     for cid, (s, p, lo, hi) in st.items() if s == status)


def _reading_sentence(result, reading: str, paper_only: bool = False) -> str:
    """One reading: reproduced under which scenarios, undecided where, else the best match."""
    from .scenarios import best_scenario
    key = "all_paper" if paper_only else "all"
    statuses = scenario_statuses(result, reading, paper_only)
    wide = result.wide(reading)
    n = result.n_studies()
    head = f"Read {reading}ly"
    repro = [k for k, s in statuses.items() if s == "reproduced"]
    undecided = [k for k, s in statuses.items() if s == "undecided"]
    if repro:
        first = max(repro, key=lambda k: wide.loc[k, key])
        others = [_name(k) for k in repro if k != first]
        return (f"{head}, reproduced under {_label(first)} (every claim's {_LEVEL} interval above "
                f"{THRESHOLD:g} after {int(n.loc[first])} studies; all in one study "
                f"{wide.loc[first, key]:.2f})" + (f", and also under {', '.join(others)}"
                                                  if others else ""))
    if undecided:
        parts = []
        for k in undecided:
            st = claim_statuses(result, k, reading, paper_only)
            parts.append(f"{_name(k)} after {int(n.loc[k])} studies: {_list(st, 'undecided')}")
        return (f"{head}, undecided at this precision: no scenario has every claim's "
                f"{_LEVEL} interval above {THRESHOLD:g}, and under {len(undecided)} scenario(s) "
                f"no claim's interval lies below it (" + "; ".join(parts) + ")")
    best = best_scenario(result, reading, key)
    st = claim_statuses(result, best, reading, paper_only)
    held = sum(s == "shown" for s, *_ in st.values())
    rest = _list(st, "undecided")
    return (f"{head}, not reproduced: every scenario has a claim whose {_LEVEL} interval lies "
            f"below {THRESHOLD:g}; best match: {_label(best)}, {held} of {len(st)} claims shown, "
            f"all in one study {wide.loc[best, key]:.2f}; below {THRESHOLD:g}: "
            f"{_list(st, 'not shown')}" + (f"; undecided: {rest}" if rest else ""))


def bias_text(result, scenario) -> str:
    """A response bias in words ("names most simulated samples 4#"), or "" without one."""
    share = result.answer_shares(scenario)
    if share is None or not np.all(np.isfinite(share)):
        return ""
    top = int(np.argmax(share))
    if share[top] < 0.5:
        return ""
    return (f"{_name(scenario)} names most simulated samples {top + 1}# ({100 * share[top]:.0f} % of its "
            f"simulated answers on average, against 25 % without a bias): a response bias, not "
            f"recognition")


def _difference(result, reading: str) -> str:
    """Which ``*`` claims (and assumptions) make the paper-only result differ, in one reading."""
    from analysis.claims import CLAIMS
    whole = scenario_statuses(result, reading)
    paper = scenario_statuses(result, reading, paper_only=True)
    changed = [k for k in whole if whole[k] != paper[k]]
    if not changed:
        return ""
    wide = result.wide(reading)
    k = max(changed, key=lambda s: (paper[s] == "reproduced", wide.loc[s, "all_paper"]))
    own = {c.id: c for c in CLAIMS if c.own}
    st = claim_statuses(result, k, reading)
    deciding = [cid for cid, (s, *_) in st.items() if cid in own and s != "shown"]
    named = "; ".join(f"{_short(cid)} {interval_text(*st[cid][1:])} ({own[cid].own})"
                      for cid in deciding)
    bias = bias_text(result, k) if "no_dominant_answer_simulated" in deciding else ""
    return (f"{reading}ly {_name(k)} goes from {whole[k]} to {paper[k]}, decided by {named}"
            + (f"; {bias}" if bias else ""))


def paper_claims_sentence(result) -> str:
    """The result on the paper's own claims alone, and what decides the difference."""
    parts = [_reading_sentence(result, r, paper_only=True).replace("Read ", "read ", 1)
             for r in ("descriptive", "inferential")]
    diffs = [d for d in (_difference(result, r) for r in ("descriptive", "inferential")) if d]
    tail = ("; the difference: " + "; ".join(diffs)) if diffs else \
        "; the * criteria change no scenario's result"
    return "On the paper's own claims alone (without the * criteria): " + "; ".join(parts) + tail


def _printed_sentence(result) -> str:
    """How the printed Eq. 7 fares in both readings (its best observer in each)."""
    parts = []
    for reading in ("descriptive", "inferential"):
        wide = result.wide(reading)
        rows = [k for k in wide.index if k[0] == PRINTED[0]]
        if not rows:
            return ""
        best = max(rows, key=lambda k: (claims_held(result, k, reading)[0], wide.loc[k, "all"]))
        held, total = claims_held(result, best, reading)
        parts.append(f"{reading} {held} of {total} claims shown at best ({best[1]} observer)")
    return "Under the printed Eq. 7 (material side): " + ", ".join(parts)


def verdict_line(result, best=None) -> str:
    """One line: both readings on every claim, the paper's claims alone, the printed Eq. 7.

    ``best`` is accepted for compatibility and not used: each reading names its own best match.
    """
    n = result.n_studies()
    printed = _printed_sentence(result)
    return (f"Figure 9 / Table 2 claims ({_LEVEL} Wilson intervals over {int(n.min())}-"
            f"{int(n.max())} simulated 15+15 studies per scenario; a claim is shown when its "
            f"interval lies above {THRESHOLD:g}). "
            + _reading_sentence(result, "descriptive") + ". "
            + _reading_sentence(result, "inferential") + ". " + paper_claims_sentence(result)
            + "." + (f" {printed}." if printed else ""))


def _mark(status: str, p: float) -> str:
    return f"{MARK[status]}{p:4.2f}"


def claims_screen(result, headline=None) -> str:
    """The claims table on one screen per reading: scenario rows, claim columns, ✓/✗/? with P."""
    from experiments.simulation.replay import REPLAY_HYPOTHESES
    blocks = []
    n = result.n_studies()
    for reading in ("descriptive", "inferential"):
        wide = result.wide(reading)
        claims = _claims(wide)
        shorts = [c.short + ("*" if c.own else "") for c in claims] + ["all", "paper"]
        head = f"{'replay':<12}{'observer':<16}" + "".join(f"{s:>10}" for s in shorts) + \
            f"{'studies':>9}"
        lines = [f"{reading.upper()}: claims {READING_TEXT[reading]}", head, "-" * len(head)]
        for k, row in wide.iterrows():
            st = claim_statuses(result, k, reading)
            cells = "".join(f"{_mark(st[c.id][0], row[c.id]):>10}" for c in claims)
            cells += f"{row['all']:>10.2f}{row.get('all_paper', float('nan')):>10.2f}"
            star = " <- headline" if headline == tuple(k) else ""
            lines.append(f"{k[0]:<12}{k[1]:<16}{cells}{int(n.loc[k]):>9}{star}")
        blocks.append("\n".join(lines))
    models = "; ".join(f"{h.name}: {h.profile_model}" for h in REPLAY_HYPOTHESES.values())
    blocks.append(f"probability that a simulated 15+15 study shows the claim; ✓ / ✗ when its "
                  f"{_LEVEL} Wilson interval lies above / below {THRESHOLD:g}, ? undecided at "
                  f"this precision; 'all': every claim in the same study, 'paper': every claim "
                  f"without *; * the project's own criterion\nprofile models: {models}")
    return "\n\n".join(blocks)

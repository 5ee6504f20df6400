"""The verdict line and the claims screen of ``reproduce figure9``: both readings of each claim."""
import pandas as pd

from analysis.claims import CLAIMS
from experiments.simulation.figure9.reproduction import claims_screen, verdict_line
from experiments.simulation.figure9.scenarios import ScenarioResult, best_scenario

# claims: rise R, rise S, 1# R, 1# S, >1/4 R, >1/4 S, no bias S, A>B R, A-B S<R, T2, all
PRINTED_ROW = [1, 0, .4, 0, 1, 0, 0, .4, .8, 0, 0]


def _result(descriptive, inferential=None):
    claims = []
    for reading, rows in (("descriptive", descriptive), ("inferential", inferential or descriptive)):
        for (h, o), probs in rows.items():
            for cid, p in zip([c.id for c in CLAIMS] + ["all"], probs):
                claims.append({"hypothesis": h, "observer": o, "reading": reading, "claim": cid,
                               "probability": p, "mc_low": p, "mc_high": p, "n_studies": 100,
                               "mean_statistic": 0.0})
    return ScenarioResult(claims=pd.DataFrame(claims), proportions=pd.DataFrame())


def test_verdict_states_both_readings():
    desc = {("printed", "absolute"): PRINTED_ROW,
            ("compensated", "absolute"): [1, 1, .6, .6, 1, 1, 1, .3, .6, 1, .12],
            ("compensated", "relative"): [1, 1, .6, .6, 1, 1, 1, .6, .6, 1, .121]}
    inf = {("printed", "absolute"): [1, 0, .2, 0, 1, 0, 0, .1, .1, 0, 0],
           ("compensated", "absolute"): [1, 1, .5, .6, 1, 1, 1, .3, .2, 1, .02],
           ("compensated", "relative"): [1, 1, .4, .4, 1, 1, 1, .2, .1, 1, .01]}
    r = _result(desc, inf)
    assert best_scenario(r, "descriptive") == ("compensated", "relative")   # 0.12 tie: mean
    assert best_scenario(r, "inferential") == ("compensated", "absolute")
    line = verdict_line(r)
    d, i = line.split(". Read inferentially")
    assert d.startswith("Figure 9 / Table 2 claims. Read descriptively, the claims are reproduced "
                        "under the compensated (real contact at the skin) replay with the "
                        "relative observer")
    assert "tied at 0.12 with 1 other scenario(s)" in d
    assert i.startswith(", no scenario reproduces the claims")
    assert "8 of 10 claims" in i and "A>B R 0.30, A-B S<R 0.20" in i
    assert line.endswith("Under the printed Eq. 7 (material side): descriptive 3 of 10 claims at "
                         "best (absolute observer), inferential 2 of 10 claims at best (absolute "
                         "observer).")


def test_verdict_says_plainly_when_no_scenario_reproduces_the_paper():
    r = _result({("printed", "absolute"): PRINTED_ROW,
                 ("skin", "absolute"): [1, 1, .6, .6, 1, .9, 0, .6, .6, 1, 0],
                 ("compensated", "absolute"): [1, 1, .45, .46, 1, 1, 1, .38, .48, 1, .10]})
    line = verdict_line(r)
    assert "Read descriptively, no scenario reproduces the claims" in line
    assert "best match: the compensated (real contact at the skin) replay with the absolute " \
           "observer, 6 of 10 claims" in line
    assert "1# low R 0.45, 1# low S 0.46, A>B R 0.38, A-B S<R 0.48" in line
    assert "reproduced under" not in line and "tied" not in line


def test_screen_has_both_readings_marks_and_headline():
    r = _result({("printed", "absolute"): PRINTED_ROW},
                {("printed", "absolute"): [0] * 11})
    screen = claims_screen(r, ("printed", "absolute")).splitlines()
    assert screen[0].startswith("DESCRIPTIVE") and screen[1].split()[:2] == ["replay", "observer"]
    assert "✓1.00" in screen[3] and "✗0.00" in screen[3] and screen[3].endswith("<- headline")
    inf = screen.index(next(s for s in screen if s.startswith("INFERENTIAL")))
    assert "✓" not in screen[inf + 3] and screen[inf + 3].endswith("<- headline")
    # the project's own criteria are starred in the header
    assert "1# low R*" in screen[1] and "no bias S*" in screen[1] and "A>B R*" not in screen[1]
    assert any(s.startswith("profile models: printed: Eq. 7 as printed") for s in screen)


def test_claims_held_and_reproducing_scenarios_per_reading():
    from experiments.simulation.figure9.reproduction import claims_held, reproducing_scenarios
    r = _result({("skin", "absolute"): [1, 1, .6, .6, 1, .9, 0, .6, .6, 1, 0],
                 ("compensated", "relative"): [1, 1, .5, .6, 1, 1, 1, .6, .6, 1, .05]},
                {("skin", "absolute"): [0] * 11, ("compensated", "relative"): [0] * 11})
    assert claims_held(r, ("skin", "absolute")) == (9, 10)
    assert claims_held(r, ("compensated", "relative")) == (10, 10)      # 0.5 counts as ✓
    assert reproducing_scenarios(r) == [("compensated", "relative")]
    assert reproducing_scenarios(r, "inferential") == []
    assert claims_held(r, ("skin", "absolute"), "inferential") == (0, 10)


def test_distribution_figure_is_written_with_the_study_on_top(tmp_path):
    from experiments.simulation.figure9.plot import claims_note, plot_figure9_distribution
    rows, observed = [], []
    for g in ("A", "B"):
        for mode in ("real", "simulated"):
            for rid, um in zip((1, 2, 3, 4), (1.6, 12.5, 50.0, 100.0)):
                rows.append({"group": g, "mode": mode, "roughness_id": rid, "roughness_um": um,
                             "study_low": .2, "study_q25": .4, "study_median": .5,
                             "study_q75": .6, "study_high": .8})
                observed.append({"group": g, "mode": mode, "roughness_id": rid,
                                 "proportion_correct": .55})
    props = pd.DataFrame(rows)
    r = _result({("printed", "absolute"): PRINTED_ROW})
    note = claims_note(r.claims, ("printed", "absolute"))
    assert note.splitlines()[1] == "1.00 / 1.00  proportion correct rises with roughness (real)"
    assert "0.40 / 0.40  1# is often confused (real) *" in note
    files = plot_figure9_distribution(props, props, pd.DataFrame(observed), tmp_path / "f.png",
                                      left_title="l", right_title="r", left_note=note,
                                      right_note=note)
    assert [f.name for f in files] == ["f.png", "f.pdf"]
    assert all(f.stat().st_size > 10_000 for f in files)

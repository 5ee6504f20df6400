"""The verdict line and the claims screen of ``reproduce figure9``."""
import pandas as pd

from analysis.claims import CLAIMS
from experiments.simulation.figure9.reproduction import claims_screen, verdict_line
from experiments.simulation.figure9.scenarios import ScenarioResult, best_scenario


def _result(rows):
    claims = []
    for (h, o), probs in rows.items():
        for cid, p in zip([c.id for c in CLAIMS] + ["all"], probs):
            claims.append({"hypothesis": h, "observer": o, "claim": cid, "probability": p,
                           "mc_low": p, "mc_high": p, "n_studies": 100, "mean_statistic": 0.0})
    return ScenarioResult(claims=pd.DataFrame(claims), proportions=pd.DataFrame())


def test_verdict_names_the_hypothesis_and_the_failing_claims():
    # claims: rise R, rise S, 1# R, 1# S, >1/4 R, >1/4 S, no bias S, A>B R, A-B S<R, T2, all
    r = _result({("material", "absolute"): [1, 0, .4, 0, 1, 0, 0, .4, .8, 0, 0],
                 ("compensated", "absolute"): [1, 1, .6, .6, 1, 1, 1, .3, .6, 1, .12],
                 ("compensated", "relative"): [1, 1, .6, .6, 1, 1, 1, .6, .6, 1, .121]})
    best = best_scenario(r)
    assert best == ("compensated", "relative")        # 'all' ties at 0.12: higher mean wins
    line = verdict_line(r, best)
    assert line.startswith("The paper's Figure 9 / Table 2 claims are reproduced under the "
                           "compensated (real contact at the skin) replay with the relative observer")
    assert "tied with compensated/absolute at 0.12, chosen by the higher mean" in line
    assert "no observer reproduces them" in line
    partly = verdict_line(r, ("compensated", "absolute"))
    assert "partly reproduced (9 of 10 claims)" in partly and "A>B R 0.30" in partly
    assert "every claim is shown by at least half of simulated studies under compensated/relative" \
        in partly


def test_verdict_says_plainly_when_no_scenario_reproduces_the_paper():
    # the all-'4#' pattern: every old claim shown, the response-bias claim never
    r = _result({("material", "absolute"): [1, 0, .4, 0, 1, 0, 0, .4, .8, 0, 0],
                 ("skin", "absolute"): [1, 1, .6, .6, 1, .9, 0, .6, .6, 1, 0],
                 ("compensated", "absolute"): [1, 1, .45, .46, 1, 1, 1, .38, .48, 1, .10]})
    best = best_scenario(r)
    assert best == ("compensated", "absolute")
    line = verdict_line(r, best)
    assert line.startswith("No scenario reproduces the paper's Figure 9 / Table 2 claims")
    assert "best match by the stated rule" in line and "6 of 10 claims" in line
    assert "1# low R 0.45, 1# low S 0.46, A>B R 0.38, A-B S<R 0.48" in line
    assert "reproduced under" not in line and "tied" not in line


def test_verdict_reports_a_tie_with_every_scenario():
    r = _result({("material", "absolute"): [1, 0, .4, 0, 1, 0, 0, .4, .8, 0, 0],
                 ("skin", "absolute"): [1, 1, .6, .6, 1, .9, 0, .6, .6, 1, 0.001]})
    best = best_scenario(r)
    assert best == ("skin", "absolute")                  # 0.00 both: higher mean 0.73 > 0.36
    line = verdict_line(r, best)
    assert line.startswith("No scenario reproduces") and "9 of 10 claims" in line
    assert "tied with every other scenario at 0.00, chosen by the higher mean probability" in line


def test_screen_marks_and_headline():
    r = _result({("material", "absolute"): [1, 0, .4, 0, 1, 0, 0, .4, .8, 0, 0]})
    screen = claims_screen(r, ("material", "absolute")).splitlines()
    assert screen[0].split()[:2] == ["replay", "observer"]
    assert "✓1.00" in screen[2] and "✗0.00" in screen[2] and screen[2].endswith("<- headline")


def test_claims_held_and_reproducing_scenarios():
    from experiments.simulation.figure9.reproduction import claims_held, reproducing_scenarios
    r = _result({("skin", "absolute"): [1, 1, .6, .6, 1, .9, 0, .6, .6, 1, 0],
                 ("compensated", "relative"): [1, 1, .5, .6, 1, 1, 1, .6, .6, 1, .05]})
    assert claims_held(r, ("skin", "absolute")) == (9, 10)
    assert claims_held(r, ("compensated", "relative")) == (10, 10)      # 0.5 counts as ✓
    assert reproducing_scenarios(r) == [("compensated", "relative")]

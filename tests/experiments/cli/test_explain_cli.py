"""``thermocue explain``: the scene planner's decisions for a scene given on the command line."""
import json

from experiments.cli import main


def test_explain_prints_each_decision(capsys):
    assert main(["explain", "--layered", "--perfusion-per-s", "1.25e-3"]) == 0
    out = capsys.readouterr().out
    assert "neglected perfusion" in out and "kept      slab" in out and "kept      layered" in out


def test_explain_json_matches_the_planner(capsys):
    from stimuli.planner import plan
    from stimuli.scene import Scene
    assert main(["explain", "--json", "--quantity", "interface_material", "--geometry", "half-space",
                 "--tolerance-K", "2", "--rate-Hz", "100"]) == 0
    data = json.loads(capsys.readouterr().out)
    direct = plan(Scene(quantity="interface_material", geometry="half-space", tolerance_K=2.0,
                        rate_Hz=100.0)).to_dict()
    assert data["method"] == direct["method"] == "eq7"
    assert [d["effect"] for d in data["decisions"]] == [d["effect"] for d in direct["decisions"]]
    assert data["scene"]["force_N"] == 2.0


def test_explain_refuses_absurd_input_in_one_line(capsys):
    assert main(["explain", "--skin-temperature-C", "-300"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "skin_temperature_C" in err

from experiments.cli import main


def test_bad_fault_spec_is_a_user_error(capsys):
    assert main(["emulator", "--faults", "melt"]) == 2
    err = capsys.readouterr().err
    assert "--faults" in err and "'melt'" in err and len(err.strip().splitlines()) == 1


def test_help_names_the_options(capsys):
    import pytest
    with pytest.raises(SystemExit):
        main(["emulator", "--help"])
    out = capsys.readouterr().out
    for opt in ("--link", "--faults", "--clock", "--log"):
        assert opt in out

"""``analyze`` and ``thermocue analyze``: every file, the report's contents, errors."""
from __future__ import annotations

import pandas as pd
import pytest

from analysis import analyze
from experiments.cli import main


def test_analyze_writes_every_table_figure_and_report(study, tmp_path):
    data, _ = study(n_per_group=8, sigma=0.4, fault_rate=0.05, seed=51)
    out = tmp_path / "out"
    steps = []
    result = analyze(data, out, n_boot=300, progress=steps.append)
    names = {"figure9.png", "confusion.png", "proportions.csv", "participants.csv", "confusion.csv",
             "gee.csv", "glmm.csv", "contrasts.csv", "exclusions.csv", "sessions.csv",
             "all_trials.csv", "report.md", "tests.csv", "chance.csv", "missing.csv",
             "missing_trials.csv", "agreement.csv", "hu.csv", "ordinal.csv", "covariates.csv",
             "rt.csv", "wide.csv", "cell_counts.csv", "codebook.json", "settings.json",
             "glmm_convergence.json"}
    assert names <= {p.name for p in out.iterdir()}
    assert all(p.stat().st_size > 0 for p in out.iterdir() if p.name != "missing_trials.csv")
    assert len(steps) >= 4
    props = pd.read_csv(out / "proportions.csv")
    assert list(props.columns[:3]) == ["group", "mode", "roughness_id"]
    assert {"proportion_correct", "wilson_low", "boot_high", "n_trials"} <= set(props.columns)
    assert len(props) == 16
    pd.testing.assert_frame_equal(props, result.proportions, check_dtype=False, atol=1e-5)
    contrasts = pd.read_csv(out / "contrasts.csv")
    assert {"gee"} <= set(contrasts["model"]) and len(contrasts[contrasts["model"] == "gee"]) == 10
    report = (out / "report.md").read_text()
    n_fam = int((result.log.trials["exclusion"] == "familiarisation").sum())
    n_fault = int((result.log.trials["exclusion"] == "status fault").sum())
    assert f"| familiarisation | {n_fam} |" in report
    assert f"| status fault | {n_fault} |" in report and n_fault > 0
    assert "16 participants" in report and "GEE" in report and "participant_sd" in report
    assert "![Figure 9](figure9.png)" in report
    assert result.summary in report
    # report.md prints only intervals whose coverage was measured (docs/analysis.md): the
    # trial-independent Wilson interval, the ordinal slope's and the covariates' intervals stay
    # in the CSVs; the random-slope model's SDs and correlation carry profile intervals
    lines = report.splitlines()

    def header_after(text):
        start = next(i for i, line in enumerate(lines) if text in line)
        return next(line for line in lines[start + 1:] if line.startswith("|"))
    assert "wilson" not in header_after("## Proportion correct") and "boot_low" in report
    assert "po_ci_low" not in header_after("Ordinal agreement") and "po_slope" in report
    assert "ci_low" not in header_after("Covariates (GEE")
    assert "ci_low" in header_after("### With a random slope")
    slope_rows = {line.split("|")[1].strip(): line for line in lines if line.startswith("| sd_")
                  or line.startswith("| corr_")}
    for term in ("sd_intercept", "sd_mode_slope", "corr_intercept_slope"):
        assert "profile likelihood, F(1, 14) cut-off" in slope_rows[term], slope_rows
    assert {"wilson_low"} <= set(pd.read_csv(out / "proportions.csv").columns)
    assert {"po_ci_low"} <= set(pd.read_csv(out / "ordinal.csv").columns)


def test_analyze_of_sessions_already_read_writes_the_same_files(study, tmp_path):
    # reproduce figure9 reads its study once for the analysis and the depth fit
    from analysis.load import load_trials
    data, _ = study(n_per_group=6, sigma=0.4, fault_rate=0.05, seed=52)
    analyze(data, tmp_path / "read", n_boot=200, mixed=False)
    log = load_trials(data)
    before = log.trials.copy()
    analyze(data, tmp_path / "given", n_boot=200, mixed=False, loaded=log)
    pd.testing.assert_frame_equal(log.trials, before)          # not changed
    tables = sorted(p.name for p in (tmp_path / "read").glob("*.csv"))
    assert len(tables) > 15 and tables == sorted(p.name for p in (tmp_path / "given").glob("*.csv"))
    for name in tables:
        assert (tmp_path / "read" / name).read_bytes() == \
            (tmp_path / "given" / name).read_bytes(), name
    with pytest.raises(ValueError,
                       match="expected sessions chosen by the 'latest' policy, got 'first'"):
        analyze(data, tmp_path / "other", n_boot=200, mixed=False, sessions="latest", loaded=log)


def test_cli_analyze(study, tmp_path, capsys):
    data, _ = study(n_per_group=4, seed=52)
    out = tmp_path / "out"
    assert main(["analyze", str(data), "--out", str(out), "--bootstrap", "200", "--no-bayes"]) == 0
    captured = capsys.readouterr()
    assert "loading sessions" in captured.err and "done" in captured.err
    assert captured.out.strip() == str(out / "report.md")
    assert (out / "figure9.png").stat().st_size > 0


def test_cli_analyze_bad_log_exits_2_naming_file_and_column(study, tmp_path, capsys):
    data, _ = study(n_per_group=1, write_events=False, seed=53)
    path = next(data.rglob("trials.csv"))
    text = path.read_text().replace("participant,group,", "participant,grp,", 1)
    path.write_text(text)
    assert main(["analyze", str(data), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("[") and "loading sessions" in err[0]        # progress, then one line
    assert len(err) == 2
    assert err[1].startswith(f"thermocue analyze: {path}: group: expected a column named 'group'")


@pytest.mark.slow   # two interpreters with the analysis's imports (~7 s)
def test_run_as_a_program_analyze_ends_without_teardown_and_loses_nothing(study, tmp_path):
    # `thermocue analyze` (main() with no arguments) ends the process itself once it succeeded:
    # the atexit functions still run, stdout and stderr arrive whole through pipes, every
    # output is complete; bad input still takes the ordinary path (exit 2, one line)
    import subprocess
    import sys
    import textwrap
    data, _ = study(n_per_group=4, seed=52)
    out, mark = tmp_path / "out", tmp_path / "atexit-ran"
    program = textwrap.dedent(f"""
        import atexit, sys
        atexit.register(lambda: open({str(mark)!r}, "w").write("ran"))
        sys.argv = ["thermocue"] + sys.argv[1:]
        from experiments.cli import main
        status = main()
        open({str(mark)!r} + ".returned", "w").write(str(status))   # not reached on success
        sys.exit(status)
        """)
    run = subprocess.run([sys.executable, "-c", program, "analyze", str(data), "--out", str(out),
                          "--bootstrap", "200", "--no-bayes"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout == f"{out / 'report.md'}\n"
    assert run.stderr.rstrip().splitlines()[-1].endswith(f"done: {out / 'report.md'}")
    assert mark.read_text() == "ran" and not (tmp_path / "atexit-ran.returned").exists()
    assert (out / "COMPLETE").is_file() and "## " in (out / "report.md").read_text()
    bad = subprocess.run([sys.executable, "-c", program, "analyze", str(tmp_path / "nowhere"),
                          "--out", str(tmp_path / "o2")], capture_output=True, text=True,
                         timeout=300)
    assert bad.returncode == 2 and (tmp_path / "atexit-ran.returned").read_text() == "2"

"""The random-slope model's six profile-interval ends, shared between ``analyze``'s forked worker
and the analysis itself (``analysis.glmm_slope_profile.complete_profiles`` takes back the ends the
worker has not started): each end is the same number whoever computes it, in whatever order."""
from __future__ import annotations

import multiprocessing
import threading
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd
import pytest

from analysis.glmm_slope import fit_glmm_slope
from analysis.glmm_slope_profile import PROFILE_ENDS, SHARE_ORDER, complete_profiles, profile_end
from analysis.worker import Job
from generator import effect_cells, generate

FORMULA = "correct ~ group * mode + C(roughness_id)"


@pytest.fixture(scope="module")
def trials():
    return generate(effect_cells(), n_a=8, n_b=8, sigma=0.5, slope_sd=1.0, seed=3)


@pytest.fixture(scope="module")
def here(trials):
    """The fit with its intervals computed in place, one end after the other."""
    return fit_glmm_slope(trials, FORMULA)


def _intervals(table: pd.DataFrame) -> np.ndarray:
    rows = table.set_index("term").loc[["sd_intercept", "sd_mode_slope", "corr_intercept_slope"]]
    return rows[["ci_low", "ci_high"]].to_numpy(float)


def test_each_end_is_the_same_number_in_any_order(trials, here):
    # the ends in reverse order, each from the fit's modes: the table's numbers to the bit
    pieces = []
    fit = fit_glmm_slope(trials, FORMULA, submit=lambda f, *a: pieces.append((f, a)) or None)
    assert fit.pending is None and len(pieces) == len(PROFILE_ENDS)   # no worker: done here
    function, args = pieces[0]
    assert function is profile_end
    data, z, theta, dev_min, n_agq, level, df, *_, modes = args
    ends = {}
    for which, side in reversed(PROFILE_ENDS):
        data.__dict__["_slope_modes"] = np.zeros((data.m, 2))       # another end's state: ignored
        ends[which, side] = profile_end(data, z, theta, dev_min, n_agq, level, df, which, side,
                                        modes)
    got = np.array([[ends[w, 0], ends[w, 1]] for w in range(3)])
    np.testing.assert_array_equal(got, _intervals(here.table))
    assert np.isfinite(got).all() and (got[:2, 0] <= got[:2, 1]).all()
    assert sorted(SHARE_ORDER) == list(range(len(PROFILE_ENDS)))


def _hold(event_path: str) -> None:
    """A job that keeps the worker busy until ``event_path`` exists."""
    import os
    while not os.path.exists(event_path):
        time.sleep(0.01)


def test_ends_the_worker_has_not_started_are_taken_back(trials, here, tmp_path):
    # the worker busy with another job: every end not yet in its process's queue is computed
    # here (at most two are handed over ahead of time), and the table is the one computed in place
    release = tmp_path / "release"
    stolen = []

    class Counting(Job):
        def steal(self):
            value = super().steal()
            if value is not None:
                stolen.append(self._args[7:9])
            return value

    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork")) as pool:
        busy = pool.submit(_hold, str(release))
        try:
            fit = fit_glmm_slope(trials, FORMULA,
                                 submit=lambda f, *a: Counting(pool.submit(f, *a), f, a))
            assert fit.pending is not None and np.isnan(_intervals(fit.table)).all()
            done_here = threading.Thread(target=complete_profiles, args=(fit,))
            done_here.start()
            # the ends are taken back while the worker is still held
            deadline = time.monotonic() + 120
            while len(stolen) < len(PROFILE_ENDS) - 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert not busy.done()
        finally:
            release.touch()                 # never leave the worker held
        done_here.join(timeout=300)
        busy.result(timeout=60)
    assert fit.pending is None
    assert len(stolen) >= len(PROFILE_ENDS) - 2, stolen
    # the last ends of SHARE_ORDER are the ones taken back
    assert [tuple(s) for s in stolen[:2]] == [PROFILE_ENDS[i] for i in SHARE_ORDER[::-1][:2]]
    np.testing.assert_array_equal(_intervals(fit.table), _intervals(here.table))


def test_ends_already_handed_to_the_worker_are_taken_back_until_it_begins_them(trials, here,
                                                                             tmp_path,
                                                                             monkeypatch):
    # through AnalysisWorker.submit each job has a claim slot: with the worker held, the caller
    # takes back all six ends, the two its process was handed ahead of time included (a plain
    # process pool's cancel cannot), and the worker, once released, skips them
    from analysis import worker as worker_module
    monkeypatch.setattr(worker_module, "can_fork", lambda: True)  # even if a thread runs
    release = tmp_path / "release"
    stolen = []

    with worker_module.AnalysisWorker() as worker:
        assert worker.submit(_hold, str(release)) is not None
        try:
            def submit(function, *args):
                job = worker.submit(function, *args)
                real_steal = job.steal

                def steal():
                    value = real_steal()
                    if value is not None:
                        stolen.append(args[7:9])
                    return value
                job.steal = steal
                return job
            fit = fit_glmm_slope(trials, FORMULA, submit=submit)
            done_here = threading.Thread(target=complete_profiles, args=(fit,))
            done_here.start()
            # all six taken back while the worker is still held
            deadline = time.monotonic() + 120
            while len(stolen) < len(PROFILE_ENDS) and time.monotonic() < deadline:
                time.sleep(0.05)
            taken_while_held = list(stolen)
        finally:
            release.touch()                 # never leave the worker held
        done_here.join(timeout=300)
    assert [tuple(s) for s in taken_while_held] == [PROFILE_ENDS[i] for i in SHARE_ORDER[::-1]]
    assert fit.pending is None
    np.testing.assert_array_equal(_intervals(fit.table), _intervals(here.table))


def test_an_end_the_worker_has_begun_is_its_own(trials, here, monkeypatch):
    # the worker free: it takes each end as it comes; whatever the caller could not claim it
    # waits for, and the table is the one computed in place
    from analysis import worker as worker_module
    monkeypatch.setattr(worker_module, "can_fork", lambda: True)
    with worker_module.AnalysisWorker() as worker:
        fit = fit_glmm_slope(trials, FORMULA, submit=worker.submit)
        assert fit.pending is not None
        first = fit.pending[0][1]
        first.result()                     # begun, and done, by the worker
        assert first.steal() is None
        complete_profiles(fit)
    np.testing.assert_array_equal(_intervals(fit.table), _intervals(here.table))


def test_the_far_side_restart_rule_gives_the_ends_of_always_restarting_in_fewer_optimisations(
        trials, monkeypatch):
    # RESTARTS: a point is optimised again from the estimate only after a warm start from
    # outside the interval; restarting after every warm start that lands above the cut-off
    # (the rule before) gives the same ends within Brent's tolerance, with more optimisations
    from analysis import glmm_slope_profile as gsp
    pieces = []
    fit_glmm_slope(trials, FORMULA, submit=lambda f, *a: pieces.append(a) or None)
    data, z, theta, dev_min, n_agq, level, df, *_, modes = pieces[0]
    calls = {"n": 0}
    real_minimize = gsp.optimize.minimize

    def counting(*args, **kwargs):
        calls["n"] += 1
        return real_minimize(*args, **kwargs)
    monkeypatch.setattr(gsp.optimize, "minimize", counting)
    ends, spent = {}, {}
    for rule in ("far-side", "always"):
        calls["n"] = 0
        ends[rule] = np.array([profile_end(data, z, theta, dev_min, n_agq, level, df, which,
                                           side, modes, restart=rule)
                               for which, side in PROFILE_ENDS])
        spent[rule] = calls["n"]
    finite = np.isfinite(ends["always"])
    np.testing.assert_array_equal(np.isfinite(ends["far-side"]), finite)
    assert np.all(np.abs(ends["far-side"] - ends["always"])[finite] <= 2e-5)
    assert spent["far-side"] < spent["always"], spent
    with pytest.raises(ValueError, match="restart"):
        profile_end(data, z, theta, dev_min, n_agq, level, df, 0, 1, modes, restart="never")

"""Nested runs and emcee ensembles as dask tasks (``[nested]`` / ``[sampler] scheduler``,
bayestissue.inference.sampling.cluster): the same runs as in forked processes, progress back in this process, bad
addresses refused, and a run whose client has gone stops."""

import time
from pathlib import Path

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.inference import NestedOptions, sample_nested
from bayestissue.inference.sampling.cluster import RunAbandoned, _task, check_scheduler
from bayestissue.workflows import load_config
from bayestissue.workflows.problem import build_problem
from tests.short_creep import short_creep, short_creep_config


def _short_creep_problem():
    """The short creep (tests/short_creep.py), two parameters sampled, known noise."""
    return build_problem([short_creep()], short_creep_config())


@pytest.mark.slow
def test_runs_on_a_local_cluster_are_the_runs_of_forked_processes():
    problem = _short_creep_problem()
    small = {"n_live": 100, "n_eff": 200, "n_runs": 2, "n_networks": 1, "report_every": 1000}
    here = sample_nested(problem, options=NestedOptions(**small, n_processes=1), rng=7)
    seen = []
    there = sample_nested(
        problem,
        options=NestedOptions(**small, n_processes=2, scheduler="local"),
        rng=7,
        progress=lambda *msg: seen.append(msg),
    )
    for a, b in zip(here.runs, there.runs, strict=True):
        assert a.log_z == b.log_z and a.n_like == b.n_like and a.seed == b.seed
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.log_w, b.log_w)
    # every report of both runs came back: (run, evaluations, n_eff, explored, log Z), the evaluations rising
    assert {m[0] for m in seen} == {0, 1}
    for k in (0, 1):
        counts = [m[1] for m in seen if m[0] == k]
        assert counts == sorted(counts) and counts[-1] == there.runs[k].n_like
        assert all(isinstance(m[3], bool) for m in seen)


@pytest.mark.parametrize("section", ["nested", "sampler"])
@pytest.mark.parametrize("bad", ["host:8786", "tcp://", "", 8786, "LOCAL"])
def test_a_scheduler_that_is_neither_local_nor_an_address_is_refused(bad, section, tmp_path):
    from bayestissue.inference import SamplerOptions

    with pytest.raises(ValidationError, match="scheduler"):
        (NestedOptions if section == "nested" else SamplerOptions)(scheduler=bad)
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(f"[{section}]\nscheduler = {bad!r}\n".replace("'", '"'))
    with pytest.raises(ValidationError, match=rf"cfg.toml \[{section}\] scheduler: expected \"local\" or a dask"):
        load_config(cfg)


def test_local_and_addresses_are_accepted():
    assert check_scheduler("local") == "local"
    assert check_scheduler("tcp://10.0.0.5:8786") == "tcp://10.0.0.5:8786"
    assert NestedOptions(scheduler=None).scheduler is None


def _reports_until_stopped(problem, marker, report):
    """A stand-in run: reports every 50 ms for up to 60 s; says in ``marker`` whether it was told to stop."""
    try:
        for i in range(1200):
            report(0, i, 0.0, False, 0.0)
            time.sleep(0.05)
    except RunAbandoned:
        Path(marker).write_text("stopped")
        raise
    Path(marker).write_text("ran to the end")


@pytest.mark.slow
def test_a_run_whose_client_lets_go_stops_at_its_next_report(tmp_path):
    from bayestissue.parallel import start_client

    client = start_client(n_workers=1)
    marker = tmp_path / "marker.txt"
    try:
        got = []
        client.subscribe_topic("t", got.append)
        fut = client.submit(_task, _reports_until_stopped, b"\x80\x04N.", (str(marker),), "t", pure=False)
        deadline = time.time() + 60
        while not got and time.time() < deadline:
            time.sleep(0.1)
        assert got, "the run never reported"
        fut.release()  # what the scheduler does to a task whose client has gone
        del fut
        while not marker.exists() and time.time() < deadline:
            time.sleep(0.1)
        assert marker.read_text() == "stopped"
    finally:
        client.close()
        client.cluster.close()


@pytest.mark.slow
def test_emcee_ensembles_on_a_local_cluster_are_the_ensembles_of_forked_processes(tmp_path, monkeypatch):
    """``[sampler] scheduler``: both rounds of the shared-proposal path (preparation, then production with the mixture
    fitted to all ensembles) as dask tasks give the forked processes' ensembles bit for bit, checkpoints included."""
    from bayestissue.inference import SamplerOptions, sample_posterior

    problem = _short_creep_problem()
    assert problem.names == ("mu", "ginf2")
    small = dict(n_walkers=8, n_ensembles=2, max_steps=200, check_every=100, prune_rounds=1, prune_steps=50,
                 adapt_rounds=1, adapt_steps=100, mixture_components=2, moves="mixture", proposal="shared")  # fmt: skip
    here = sample_posterior(problem, [2.18, 13.4], options=SamplerOptions(**small, n_processes=2), rng=11)

    def no_forks(*a):
        raise AssertionError("the ensembles went to forked processes")

    monkeypatch.setattr("bayestissue.inference.sampling.cluster.run_in_processes", no_forks)
    seen = []
    there = sample_posterior(
        problem,
        [2.18, 13.4],
        options=SamplerOptions(**small, n_processes=2, scheduler="local"),
        checkpoint=tmp_path,
        rng=11,
        progress=lambda *msg: seen.append(msg),
    )
    np.testing.assert_array_equal(here.kept_z(), there.kept_z())
    np.testing.assert_array_equal(here.kept_log_prob(), there.kept_log_prob())
    assert here.n_evaluations == there.n_evaluations > 2 * 8 * 200
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ensemble_0.h5", "ensemble_1.h5"]
    # progress of both ensembles came back: (ensemble, steps done, steps total, phase)
    assert {m[0] for m in seen} == {0, 1}
    assert max(m[1] for m in seen if m[0] == 0) == 200

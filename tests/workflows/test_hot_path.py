"""The sampler's hot path: at most 4 Python frames from emcee's call to the numba kernel, fixed inputs computed once.

Deterministic checks (no timing): the kernel is replaced by a recording wrapper that walks the stack up to
``log_posterior_unconstrained`` (the function emcee calls); the experiment's load and interpolation are counted.
``benchmarks/bench_overhead.py`` prints the time this saves.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import bayestissue.mechanics.forward as forward_module
from bayestissue.mechanics import Experiment, load_experiment
from bayestissue.paper import MIRROR_TIES, PAPER_PARAMETERS
from bayestissue.workflows import CalibrationConfig, build_problem

DATA = Path(__file__).resolve().parents[2] / "data"


def _t1_problem(coordinates="creep"):
    exp = load_experiment(DATA / "T1.toml")
    return build_problem([exp], CalibrationConfig(tied=dict(MIRROR_TIES), coordinates=coordinates))


def _batch(problem, n=6):
    p = np.tile(PAPER_PARAMETERS["T1"], (n, 1))
    cols = [problem.material.names.index(name) for name in problem.material.sampled_names]
    theta = np.column_stack([p[:, cols], np.full(n, 0.02)])
    return problem.coordinates.to_unconstrained(theta)


def test_at_most_four_frames_from_the_sampler_target_to_the_kernel(monkeypatch):
    problem = _t1_problem()
    z = _batch(problem)
    kernel, chains = forward_module.solve_batch, []

    def recording(*args):
        frame, names = sys._getframe(1), []
        while frame is not None and frame.f_code.co_name != "log_posterior_unconstrained":
            names.append(frame.f_code.co_name)
            frame = frame.f_back
        chains.append([*names, "log_posterior_unconstrained"][::-1])
        return kernel(*args)

    monkeypatch.setattr(forward_module, "solve_batch", recording)
    lp = problem.log_posterior_unconstrained(z)
    assert np.all(np.isfinite(lp))
    assert chains == [["log_posterior_unconstrained", "log_posterior", "log_likelihood", "__call__"]]


def test_fixed_inputs_are_computed_once_per_experiment(monkeypatch):
    problem = _t1_problem()
    z = _batch(problem)
    calls = {"load": 0, "interp": 0}
    load, interp = Experiment.nominal_stress_kpa, Experiment.interpolation

    def counted_load(self):
        calls["load"] += 1
        return load(self)

    def counted_interp(self):
        calls["interp"] += 1
        return interp(self)

    monkeypatch.setattr(Experiment, "nominal_stress_kpa", counted_load)
    monkeypatch.setattr(Experiment, "interpolation", counted_interp)
    for _ in range(3):
        problem.log_posterior_unconstrained(z)
    assert calls == {"load": 0, "interp": 0}
    fresh = _t1_problem("box")  # building the problem computes them, once per experiment
    assert calls == {"load": 1, "interp": 1}
    np.testing.assert_array_equal(
        fresh.log_likelihood(problem.coordinates.from_unconstrained(z)),
        problem.log_likelihood(problem.coordinates.from_unconstrained(z)),
    )

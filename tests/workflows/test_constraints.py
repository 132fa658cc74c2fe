"""The likelihood-ratio test of ties and fixed values (bayestissue.workflows.constraints): true constraints are not
rejected, false ones are, with the noise sd known or profiled out; every fit reports it."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bayestissue.inference import fit_least_squares
from bayestissue.mechanics import ForwardModel, load_experiment
from bayestissue.workflows import load_config, run_calibration
from bayestissue.workflows.constraints import constraint_test
from bayestissue.workflows.problem import build_problem

T1 = Path(__file__).resolve().parents[2] / "data" / "T1.toml"
MIRROR = {"ginf3": "ginf2", "gamma3": "gamma2", "beta3": "beta2"}
SD = 0.01  # mm, about 0.5 % of the creep's displacement
#: T1's creep with mirror families (ties true) and with families 2 and 3 apart (the issue's staircase values)
MIRRORED = [2.18, 2.91, 125, 0.75, 1.25, 13.4, 0.891, 0.0005, 13.4, 0.891, 0.0005]
APART = [2.18, 2.91, 125, 0.75, 1.25, 22, 0.7, 0.01, 15, 0.8, 0.004]


def _synthetic(params, seed=3):
    e = load_experiment(T1)
    y = ForwardModel(e)(np.asarray(params, float)[None])[0]
    noise = SD * np.random.default_rng(seed).standard_normal(y.size)
    return replace(e, displacement_mm=y + noise, noise_sd_mm=SD, meta={})


def _test(exp, **cfg):
    config = load_config(None, sample=False, **cfg)
    problem = build_problem([exp], config)
    best = fit_least_squares(problem, space="unit")
    return constraint_test([exp], config, problem, best)


@pytest.mark.parametrize("noise", [{"sd": "data"}, {}], ids=["sd known", "sd profiled"])
def test_true_ties_stand_false_ties_fall(noise):
    ok = _test(_synthetic(MIRRORED), tied=MIRROR, noise_options=noise)
    bad = _test(_synthetic(APART), tied=MIRROR, noise_options=noise)
    assert ok.df == bad.df == 3 and ok.released == ("ginf3", "gamma3", "beta3")
    assert ok.known_sd == ("sd" in noise)
    assert not ok.rejected and ok.p_value > 0.1, ok.text()
    assert bad.rejected and bad.p_value < 1e-4, bad.text()
    assert "REJECTED" in bad.text() and "not rejected" in ok.text()
    assert bad.cost_free <= bad.cost_constrained


def test_a_wrong_fixed_value_is_rejected():
    exp = _synthetic(MIRRORED)
    right = _test(exp, fixed={"mu": 2.18}, noise_options={"sd": "data"})
    wrong = _test(exp, fixed={"mu": 20.0}, noise_options={"sd": "data"})
    assert right.df == wrong.df == 1
    assert not right.rejected and wrong.rejected, (right.text(), wrong.text())


def test_no_constraints_no_test_and_the_fit_reports_it():
    exp = _synthetic(APART)
    assert _test(exp) is None
    lines = []
    out = run_calibration([exp], load_config(None, sample=False, n_starts=0, tied=MIRROR), say=lines.append)
    assert out.constraints is not None and out.constraints.rejected
    assert out.table["meta"]["constraint_test"] == out.constraints.text()
    assert any(line.startswith("ties and fixed values (ginf3, gamma3, beta3)") for line in lines)
    # least squares only: the tissue terms at the optimum
    assert out.tissue_terms is not None and "one parameter set" in out.tissue_terms.markdown()

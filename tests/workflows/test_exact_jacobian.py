"""The exact residual Jacobian through the problem's parameter layout, and the warm start that uses it."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.inference import fit_least_squares
from bayestissue.mechanics import load_experiment
from bayestissue.paper import MIRROR_TIES, PAPER_PARAMETERS
from bayestissue.workflows.config import CalibrationConfig
from bayestissue.workflows.problem import build_problem


@pytest.fixture(scope="module")
def experiments():
    return [load_experiment("data/T1.toml"), load_experiment("data/T2.toml")]


def _central(problem, x, rel=1e-4):
    cols = []
    for j in range(x.size):
        h = rel * abs(x[j])
        up, down = x.copy(), x.copy()
        up[j] += h
        down[j] -= h
        cols.append((problem.residuals(up[None])[0] - problem.residuals(down[None])[0]) / (2 * h))
    return np.column_stack(cols)


@pytest.mark.parametrize("tied", [{}, dict(MIRROR_TIES)], ids=["full", "mirror"])
def test_residual_jacobian_matches_central_differences_with_ties_and_two_experiments(experiments, tied):
    """Central differences of the residuals (relative step 1e-4): truncation ~1e-8 and forward-solve noise
    ~1e-10 mm / h; agreement to 1e-5 of each column's largest entry is well above both and far below any
    error in the chain through the ties (which would be O(1))."""
    problem = build_problem(experiments, CalibrationConfig(tied=tied, noise_options={"sd": "data"}))
    full = PAPER_PARAMETERS["T1"]
    x = np.array([full[problem.material.names.index(n)] for n in problem.material.sampled_names])
    r, jac = problem.residual_jacobian(x[None])
    np.testing.assert_array_equal(r, problem.residuals(x[None]))
    fd = _central(problem, x)
    assert jac.shape == (1, problem.n_obs, x.size)
    scale = np.abs(fd).max(axis=0)
    assert np.all(np.abs(jac[0] - fd).max(axis=0) <= 1e-5 * scale), np.abs(jac[0] - fd).max(axis=0) / scale


def test_exact_warm_start_reaches_the_same_optimum_and_is_refused_without_sensitivities(experiments):
    problem = build_problem(experiments[:1], CalibrationConfig())
    fd = fit_least_squares(problem, PAPER_PARAMETERS["T1"])
    exact = fit_least_squares(problem, PAPER_PARAMETERS["T1"], jacobian="exact")
    assert exact.status > 0 and fd.status > 0  # both stopped on a tolerance, not on max_nfev
    assert exact.cost == pytest.approx(fd.cost, rel=1e-6)
    # the reported Jacobian is the exact one at the optimum (the forward differences' step sqrt(eps) max(|x|, x0)
    # is ~1e-11 for beta2 ~ 5e-4, below the forward solve's noise, so the two reported Jacobians differ there)
    np.testing.assert_array_equal(exact.jac, problem.residual_jacobian(exact.x[None])[1][0])
    specimen = build_problem(experiments, CalibrationConfig(specimen=("scale", "T2")))
    with pytest.raises(ValidationError, match="jacobian"):
        fit_least_squares(specimen, jacobian="exact")
    with pytest.raises(ValidationError, match="jacobian"):
        fit_least_squares(problem, jacobian="complex")


def test_config_jacobian_exact_reaches_the_pipeline(experiments):
    from bayestissue.workflows import run_calibration
    from bayestissue.workflows.config import config_from_mapping

    cfg = config_from_mapping(
        {"warmstart": {"n_starts": 1, "max_nfev": 60, "jacobian": "exact"}, "sampler": {"sample": False}}
    )
    out = run_calibration(experiments[1:], cfg)
    direct = fit_least_squares(out.problem, max_nfev=60, jacobian="exact")
    assert out.paper_fit.cost == direct.cost and out.paper_fit.nfev == direct.nfev
    fd = fit_least_squares(out.problem, max_nfev=60)
    assert out.paper_fit.njev == direct.njev and (fd.nfev, fd.cost) != (direct.nfev, direct.cost)

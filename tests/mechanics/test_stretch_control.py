"""Displacement-controlled (stretch-controlled) tests: the kernel against the independent NumPy solver, a round trip
through the force-controlled path, and the matrix-only closed forms."""

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from bayestissue._validation import ValidationError
from bayestissue.mechanics import Experiment, TissueConfig, load_experiment, simulate
from bayestissue.mechanics.forward import ForwardModel
from bayestissue.mechanics.protocols import (
    MeasuredForceProtocol,
    MeasuredStretchProtocol,
    StretchCyclesProtocol,
    StretchRampProtocol,
)
from bayestissue.mechanics.reference import reference_complex_step, reference_simulate_experiment
from bayestissue.paper import PAPER_PARAMETERS
from bayestissue.workflows import config_from_mapping
from bayestissue.workflows.problem import build_problem

SPECIMEN = (5.33, 2.43, 3.9)
TIMES = np.arange(0.0, 1201.0, 10.0)
#: the paper's initial guess, both Table 1 results, and a set with three different fibre laws
SETS = {
    **{k: PAPER_PARAMETERS[k] for k in ("initial", "T1", "T2")},
    "distinct": [1.0, 5.0, 50, 0.6, 0.02, 30, 0.85, 0.001, 8, 0.3, 1.0],
}
PROTOCOLS = {"relaxation": StretchRampProtocol(1.25, 600.0), "cycles": StretchCyclesProtocol(1.2, 400.0)}
MATRIX_ONLY = TissueConfig(directions=[], phi_fibres=[], phi_matrix=1.0, bulk_kpa=2.0e6)


@pytest.mark.parametrize("protocol", PROTOCOLS)
@pytest.mark.parametrize("key", SETS)
def test_stretch_control_matches_independent_solver(protocol, key):
    """Nominal stress at every step against scipy.optimize.root on the five free equations (reference.py): 1e-8 of
    the largest stress (the reference solves to tol 1e-10; measured 2e-11 to 3e-10). The cycles unload to stretch 1,
    where the fibres go slack and reload: the tension switch is crossed twice per cycle."""
    exp = Experiment("x", SPECIMEN, PROTOCOLS[protocol], TIMES, 5.0)
    run = ForwardModel(exp)(SETS[key], full=True)
    ref = reference_simulate_experiment(exp, SETS[key])
    assert run.ok[0] and np.all(np.isfinite(ref))
    stress = run.step_stress_kpa[0]
    np.testing.assert_allclose(stress, ref, rtol=0, atol=1e-8 * np.abs(ref).max())
    if protocol == "cycles":  # the fibres did go slack and come back
        assert run.tension_kpa[0, 1:, 1:].min() == 0.0 and run.tension_kpa[0, :, 1:].max() > 0.1


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_round_trip_through_force_control(protocol):
    """The force of a stretch-controlled run, fed back as a measured force history on the same step grid, gives back
    the prescribed displacement: to 1e-8 mm (Newton's step tolerance leaves ~1e-11 in strain; measured <= 5e-10)."""
    for key in ("T1", "T2"):
        exp = Experiment("x", SPECIMEN, PROTOCOLS[protocol], TIMES, 5.0)
        run = ForwardModel(exp)(PAPER_PARAMETERS[key], full=True)
        force = run.step_stress_kpa[0] * exp.area_mm2
        back = Experiment("y", SPECIMEN, MeasuredForceProtocol(exp.step_time_s, force), TIMES, 5.0)
        np.testing.assert_allclose(simulate(back, PAPER_PARAMETERS[key]), run.displacement_mm[0], rtol=0, atol=1e-8)


def _lateral_closed_form(lam, mu, kappa, bulk):
    """Matrix-only uniaxial stretch, compressible: C = diag(lam^2, t^2, t^2); solve S22(t) = 0 by bisection and
    return P11 = lam S11 (docs/model.md's matrix and volumetric stresses written out for a diagonal C)."""

    def stresses(t):
        c = np.array([lam**2, t**2, t**2])
        J = lam * t * t
        I1, I2 = c.sum(), c[0] * c[1] + c[0] * c[2] + c[1] * c[2]
        S = mu * J ** (-2 / 3) * (1 - I1 / 3 / c) + kappa * J ** (-4 / 3) * (I1 - c - 2 / 3 * I2 / c)
        return S + bulk * (J - 1) * J / c

    t = brentq(lambda t: stresses(t)[1], 0.2 / np.sqrt(lam), 2.0, xtol=1e-15)
    return lam * stresses(t)[0]


def test_matrix_only_closed_forms():
    """Matrix only (no fibre family): the compressible solution of the scalar lateral equation to 1e-9, and the
    incompressible Mooney-Rivlin limit P = (lam - lam^-2)(mu + kappa/lam) = 2 (lam - lam^-2)(C10 + C01/lam) with
    mu = 2 C10, kappa = 2 C01 to 5e-4 at K/mu = 6700 (the volumetric compliance; 3e-4 measured at stretch 3)."""
    exp = Experiment("m", (1.0, 1.0, 1.0), StretchRampProtocol(3.0, 10.0), np.arange(11.0), 1.0, tissue=MATRIX_ONLY)
    mu, kappa = 300.0, 50.0
    stress = simulate(exp, [mu, kappa])
    lam = exp.prescribed()
    exact = np.array([0.0] + [_lateral_closed_form(x, mu, kappa, MATRIX_ONLY.bulk_kpa) for x in lam[1:]])
    np.testing.assert_allclose(stress, exact, rtol=1e-9, atol=1e-9)
    incompressible = (lam - lam**-2) * (mu + kappa / lam)
    np.testing.assert_allclose(stress[1:], incompressible[1:], rtol=5e-4)
    assert exp.observable[:2] == ("force", "mN")


def test_measured_stretch_file(tmp_path):
    """A measured stretch history with nominal stress data: the observable is the stress, the problem fits it, and
    its exact sensitivities approach the incompressible closed form's (K = 1e6 kPa)."""
    (tmp_path / "s.csv").write_text("time_s,stretch,nominal_stress_kpa\n1,1.1,20\n2,1.2,40\n3,1.3,60\n")
    (tmp_path / "s.toml").write_text(
        'name = "S"\n[specimen]\nlength_x_mm = 1\nlength_y_mm = 1\nlength_z_mm = 1\n'
        '[protocol]\nkind = "measured_stretch"\n[simulation]\ndt_s = 1.0\n[data]\nfile = "s.csv"\n'
        "[tissue]\ndirections = []\nphi_fibres = []\nphi_matrix = 1.0\nbulk_kpa = 1e6\n"
    )
    exp = load_experiment(tmp_path / "s.toml")
    assert isinstance(exp.protocol, MeasuredStretchProtocol)
    assert exp.observable[:2] == ("nominal stress", "kPa")
    np.testing.assert_allclose(exp.prescribed(), [1.0, 1.1, 1.2, 1.3])
    problem = build_problem([exp], config_from_mapping(None))
    assert problem.names == ("mu", "kappa", "sigma_S")
    pred = problem.predict_material([[100.0, 10.0]])[0][0]
    lam = np.array([1.1, 1.2, 1.3])
    np.testing.assert_allclose(pred, (lam - lam**-2) * (100 + 10 / lam), rtol=1e-4)
    y, dy = ForwardModel(exp).sensitivities([100.0, 10.0])  # incompressible limit: dP/dmu, dP/dkappa closed form
    np.testing.assert_allclose(dy, np.column_stack([lam - lam**-2, (lam - lam**-2) / lam]), rtol=1e-4)


@pytest.mark.parametrize("protocol", PROTOCOLS)
@pytest.mark.parametrize("key", SETS)
def test_stretch_control_sensitivities_match_complex_step(protocol, key):
    """d P11 / d p at every step and for every parameter against the complex-step derivative of the independent
    implementation (reference.py, stretch control), to 1e-8 of each column's largest value: the stored states are
    converged to ~1e-11 in strain, the complex step is exact to round-off; plus 1e-14 of the largest derivative of
    any parameter, the round-off where the cycles bring the stretch back to 1 and P11 is zero whatever the
    parameters (measured 5e-16 there). The cycles cross the tension switch."""
    exp = Experiment("x", SPECIMEN, PROTOCOLS[protocol], np.arange(0.0, 801.0, 20.0), 10.0)
    p = np.asarray(SETS[key], dtype=float)
    fm = ForwardModel(exp)
    du = fm._run(p[None, :].copy(), False, True)[5][:, :, 0, :]
    refs = np.column_stack([reference_complex_step(exp, p, j) for j in range(p.size)])
    floor = 1e-14 * np.abs(refs).max()  # round-off where P11 is 0 whatever the parameters (stretch back at 1)
    for j in range(p.size):
        atol = 1e-8 * np.abs(refs[:, j]).max() + floor
        np.testing.assert_allclose(du[0, :, j], refs[:, j], rtol=0, atol=atol, err_msg=f"parameter {j}")


def test_measured_stretch_refusals():
    with pytest.raises(ValidationError, match="stretch at time_s = 0: expected 1"):
        MeasuredStretchProtocol(np.array([0.0, 1.0]), np.array([1.1, 1.2]))
    with pytest.raises(ValidationError, match="stretch: expected finite stretches > 0"):
        MeasuredStretchProtocol(np.array([1.0, 2.0]), np.array([1.1, -1.0]))
    exp = Experiment("x", SPECIMEN, StretchRampProtocol(1.2, 10.0), TIMES, 5.0)
    with pytest.raises(ValidationError, match="a force-controlled protocol"):
        exp.nominal_stress_kpa()


def test_joint_force_and_stretch_controlled_problem():
    """One posterior over a force-controlled test (displacement observed, mm) and a stretch-controlled one (force
    observed, mN): shared material parameters, one noise sd each in its own unit, the likelihood finite."""
    t1 = load_experiment(Path(__file__).resolve().parents[2] / "data" / "T1.toml")
    relax = Experiment("R", SPECIMEN, PROTOCOLS["relaxation"], TIMES, 5.0)
    force = ForwardModel(relax)(PAPER_PARAMETERS["T1"])
    relax = Experiment("R", SPECIMEN, PROTOCOLS["relaxation"], TIMES, 5.0, force_mN=force)
    problem = build_problem([t1, relax], config_from_mapping(None))
    sigmas = {s.name: s.unit for s in problem.parameters.specs if s.name.startswith("sigma_")}
    assert sigmas == {"sigma_T1": "mm", "sigma_R": "mN"}
    theta = problem.nuisance_estimate(np.asarray(PAPER_PARAMETERS["T1"]))
    assert np.isfinite(problem.log_posterior(theta))
    preds = problem.predict(theta[None, :])
    np.testing.assert_allclose(preds[1][0], force, rtol=1e-12)


def test_failed_set_is_a_nan_row():
    """Without matrix stiffness the lateral equations have no stiffness in shear under stretch control: that set's
    solve fails and comes back as a NaN row; the sets beside it in the batch are those computed alone."""
    exp = Experiment("x", SPECIMEN, PROTOCOLS["relaxation"], TIMES, 5.0)
    bad = PAPER_PARAMETERS["T1"].copy()
    bad[0] = bad[1] = 0.0
    fm = ForwardModel(exp)
    out = fm(np.stack([PAPER_PARAMETERS["T1"], bad, PAPER_PARAMETERS["T2"]]))
    assert np.isnan(out[1]).all() and np.isfinite(out[[0, 2]]).all()
    np.testing.assert_array_equal(out[0], fm(PAPER_PARAMETERS["T1"]))
    np.testing.assert_array_equal(out[2], fm(PAPER_PARAMETERS["T2"]))
    _, dy = fm.sensitivities(np.stack([PAPER_PARAMETERS["T1"], bad]))
    assert np.isnan(dy[1]).all() and np.isfinite(dy[0]).all()

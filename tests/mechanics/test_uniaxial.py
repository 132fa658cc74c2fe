"""The reduced FE model of the uniaxial tests: closed forms, an independent solver, symmetry, batching."""

import numpy as np
import pytest
from scipy.optimize import root

from bayestissue.mechanics import (
    PAPER_TISSUE,
    CreepProtocol,
    Experiment,
    KelvinFibres,
    MeasuredForceProtocol,
    RampProtocol,
    TissueConfig,
    load_experiment,
    simulate,
)
from bayestissue.mechanics.reference import reference_simulate_experiment
from bayestissue.paper import PAPER_PARAMETERS


def creep(stress=10.6, *, tissue=PAPER_TISSUE, t_end=1200.0, dt=6.0, data_step=3.0):
    t = np.arange(0.0, t_end + data_step / 2, data_step)
    return Experiment("creep", (5.33, 2.43, 3.9), CreepProtocol(stress), t, dt, tissue=tissue)


def test_single_fibre_creep_converges_to_closed_form_at_first_order():
    """eps(t) = (tau0/ginf)(1 - gamma exp(-beta t)) (docs/model.md). The midpoint history update of eq. (7) treats the
    load jump at t = 0 as if it happened half a step later, an O(dt) error: observed order 1 (measured 0.89, 0.95,
    0.97, 0.99 for dt = 4 ... 0.25 s; the finest two asserted within 0.05 of 1)."""
    fibre = KelvinFibres(ginf=10.0, gamma=0.6, beta=0.05)
    t_end, tau0 = 60.0, 3.0
    errors = []
    dts = [4.0, 2.0, 1.0, 0.5, 0.25]
    for dt in dts:
        t = np.arange(0.0, t_end + dt / 2, dt)
        eps = fibre.strain_for_constant_tension(tau0, t)
        exact = tau0 / 10.0 * (1 - 0.6 * np.exp(-0.05 * t))
        errors.append(np.abs(eps[1:] - exact[1:]).max())
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[-1] < 2e-3
    assert np.all(orders > 0.85), orders  # pre-asymptotic at dt = 4 s (beta dt = 0.2)
    assert np.all(np.abs(orders[-2:] - 1.0) < 0.05), orders


def _matrix_only_root(P, mu, kappa, bulk):
    """Independent answer: principal stretches (l1, l2 = l3) from the strain energy written directly,
    W = mu/2 (J^-2/3 I1 - 3) + kappa/2 (J^-4/3 I2 - 3) + K/2 (J - 1)^2, with dW/dl1 = P and dW/dl2 = 0 (lateral
    faces free), derivatives by complex step (exact to round-off)."""

    def W(l1, l2):
        J = l1 * l2 * l2
        I1 = l1**2 + 2 * l2**2
        I2 = 2 * l1**2 * l2**2 + l2**4
        return mu / 2 * (J ** (-2 / 3) * I1 - 3) + kappa / 2 * (J ** (-4 / 3) * I2 - 3) + bulk / 2 * (J - 1) ** 2

    def eqs(x, load):
        h = 1e-30
        l1, l2 = x
        return [W(l1 + 1j * h, l2).imag / h - load, W(l1, l2 + 1j * h).imag / h]

    x = np.array([1.0, 1.0])
    for load in np.linspace(0.05, 1.0, 20) * P:  # load continuation from the unloaded state
        x = root(eqs, x, args=(load,), tol=1e-13).x
    assert np.abs(eqs(x, P)).max() < 1e-9  # kPa
    return x


@pytest.mark.parametrize("stress", [0.5, 10.6, 40.0])
def test_matrix_only_matches_independent_strain_energy_solution(stress):
    tissue = TissueConfig(directions=[[1, 0, 0]], phi_fibres=[0.0], phi_matrix=1.0)
    exp = creep(stress, tissue=tissue, t_end=12.0)
    mu, kappa = 3.0, 1.5
    res = simulate(exp, [mu, kappa, 1.0, 0.5, 0.1], full=True)
    l1, l2 = _matrix_only_root(stress, mu, kappa, 1000.0)
    E = res.strain[0, -1]
    np.testing.assert_allclose(np.sqrt(1 + 2 * E[0]), l1, rtol=1e-10)
    np.testing.assert_allclose(np.sqrt(1 + 2 * E[1:3]), [l2, l2], rtol=1e-10)
    np.testing.assert_allclose(res.displacement_mm[0, -1], (l1 - 1) * 5.33, rtol=1e-10)
    assert np.abs(E[3:]).max() < 1e-14


def test_full_model_matches_independent_scipy_root_integration():
    """Independent NumPy + scipy.optimize.root integration of the same six equations (with fibres, viscous
    history and shear): agreement to 1e-8 mm over the whole T1 curve for the paper's T1 parameters."""
    exp = load_experiment("data/T1.toml")
    for key in ("T1", "T2"):
        p = PAPER_PARAMETERS[key]
        ref = reference_simulate_experiment(exp, p)
        ours = simulate(exp, p, full=True).step_displacement_mm[0]
        np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-8)


def test_mirror_symmetric_fibres_give_no_shear_and_asymmetric_ones_do():
    exp = creep()
    sym = simulate(exp, PAPER_PARAMETERS["T2"], full=True)  # fibres 2 and 3 identical
    asym = simulate(exp, PAPER_PARAMETERS["T1"], full=True)  # beta2 != beta3
    assert np.abs(sym.strain[0, :, 3:]).max() < 1e-12
    assert np.abs(asym.strain[0, :, 3]).max() > 1e-3  # E12
    assert np.abs(asym.strain[0, :, 4:]).max() < 1e-12  # no out-of-plane shear: fibres lie in the x-y plane


def test_fibre_along_y_carries_no_tension_under_x_tension():
    for key in ("initial", "T1", "T2"):
        res = simulate(creep(), PAPER_PARAMETERS[key], full=True)
        assert res.ok.all()
        np.testing.assert_array_equal(res.tension_kpa[0, :, 0], 0.0)
        assert res.tension_kpa[0, -1, 1:].min() > 0.1


def test_creep_is_monotone_and_instant_response_on_first_step():
    res = simulate(creep(), PAPER_PARAMETERS["T1"], full=True)
    u = res.step_displacement_mm[0]
    assert u[0] == 0.0 and u[1] > 0.1
    assert np.all(np.diff(u[1:]) >= -1e-12)


def test_batch_equals_loop_bit_for_bit_and_failures_stay_in_their_row():
    exp = load_experiment("data/T2.toml")
    rng = np.random.default_rng(5)
    base = PAPER_PARAMETERS["initial"]
    sets = base * np.exp(rng.normal(0, 0.3, (6, 11)))
    sets[:, [3, 6, 9]] = rng.uniform(0.1, 0.9, (6, 3))
    # no shear stiffness at all (only the volumetric penalty): isochoric stretching is free, no equilibrium
    sets[2] = [0.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.5, 1.0, 0.0, 0.5, 1.0]
    batch = simulate(exp, sets)
    assert np.isnan(batch[2]).all()
    for i in range(6):
        single = simulate(exp, sets[i])
        np.testing.assert_array_equal(batch[i], single)
    assert np.isfinite(np.delete(batch, 2, axis=0)).all()


def test_same_input_same_output():
    exp = load_experiment("data/T1.toml")
    a = simulate(exp, PAPER_PARAMETERS["T1"])
    b = simulate(exp, PAPER_PARAMETERS["T1"])
    np.testing.assert_array_equal(a, b)


def test_measured_force_history_reproduces_ideal_ramp():
    """A force history sampled from the ramp (with a kink at the end of the hold) gives the same curve."""
    exp = load_experiment("data/T2.toml")
    t_f = np.array([0.0, 1e-9, 240.0, 852.0])
    P = exp.protocol.nominal_stress_kpa(np.array([1.0, 1.0, 240.0, 852.0]), exp.area_mm2)
    measured = MeasuredForceProtocol(t_f, P * exp.area_mm2)
    exp_m = Experiment(exp.name, exp.specimen_mm, measured, exp.time_s, exp.dt_s)
    np.testing.assert_allclose(
        simulate(exp_m, PAPER_PARAMETERS["T2"]),
        simulate(exp, PAPER_PARAMETERS["T2"]),
        rtol=1e-9,
        atol=1e-12,
    )


def test_ramp_protocol_values():
    p = RampProtocol(hold_stress_kpa=1.6, hold_s=240.0, rate_kpa_per_s=0.054)
    np.testing.assert_allclose(
        p.nominal_stress_kpa(np.array([0.0, 6.0, 240.0, 300.0]), 6.0),
        [0.0, 1.6, 1.6, 1.6 + 0.054 * 60],
    )


def test_data_times_between_steps_are_interpolated():
    exp = creep(dt=6.0, data_step=3.0)
    res = simulate(exp, PAPER_PARAMETERS["T1"], full=True)
    u = res.step_displacement_mm[0]
    obs = res.displacement_mm[0]
    assert obs[1] == u[1]  # 0 < t < dt: the state of the first loaded step
    np.testing.assert_allclose(obs[3], 0.5 * (u[1] + u[2]))  # t = 9 s
    np.testing.assert_array_equal(obs[::2], u)

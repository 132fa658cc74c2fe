"""Sampler coordinates: the creep-curve reparametrisation (workflows.coordinates) is exact, and the ramp
coordinates' shear straightens the T2 valley without touching the Jacobian.

Its log-Jacobian is checked against finite differences of the full inverse map and, through the
sampler's own path, by drawing the box prior in the new coordinates (KS per marginal); dropping the
gamma(1 - gamma) factor of the Jacobian must be caught.
"""

from pathlib import Path

import numpy as np
import pytest
from inference_helpers import prior_only_problem
from scipy import stats

from bayestissue.inference import SamplerOptions, initial_walkers, run_ensemble
from bayestissue.inference.coordinates import make_coordinates
from bayestissue.mechanics import PAPER_TISSUE
from bayestissue.workflows import paper_parameter_set
from bayestissue.workflows.coordinates import CreepCoordinates, coordinate_advice, coordinate_factory
from bayestissue.workflows.problem import reference_stretch

TIED = {"ginf3": "ginf2", "gamma3": "gamma2", "beta3": "beta2"}


def _creep(pars):
    fibres = [(PAPER_TISSUE.phi_fibres[k], PAPER_TISSUE.directions[k]) for k in (1, 2)]
    return CreepCoordinates(pars, stretch=1.5, phi_matrix=PAPER_TISSUE.phi_matrix, fibres=fibres)


def _pars(fix_fibre1=True):
    pars = paper_parameter_set().updated(tied=TIED)
    return pars.updated(fixed=["ginf1", "gamma1", "beta1"]) if fix_fibre1 else pars


def _fd_log_det(coords, z, h=1e-6) -> float:
    """log|det d theta / d z| by central differences of the full inverse map (relative error ~1e-8 per
    entry, so the log-determinant to ~1e-6)."""
    jac = np.empty((z.size, z.size))
    for j in range(z.size):
        dz = np.zeros_like(z)
        dz[j] = h
        jac[:, j] = (coords.from_unconstrained(z + dz) - coords.from_unconstrained(z - dz)) / (2 * h)
    return float(np.linalg.slogdet(jac)[1])


def test_round_trip_and_log_jacobian_match_finite_differences():
    pars = _pars(fix_fibre1=False)
    coords = _creep(pars)
    rng = np.random.default_rng(3)
    theta = pars.sample_prior(40, rng=rng)
    z = coords.to_unconstrained(theta)
    assert np.all(np.isfinite(z))
    np.testing.assert_allclose(coords.from_unconstrained(z), theta, rtol=1e-9)
    for zi in z[:10]:
        assert coords.log_abs_det_jacobian(zi[None])[0] == pytest.approx(_fd_log_det(coords, zi), abs=1e-5)


def _prior_draws(problem, seed, n_steps=3000):
    opts = SamplerOptions(n_walkers=40, max_steps=n_steps, check_every=n_steps, prune_rounds=0, tau_factor=1e9)
    rng = np.random.default_rng(seed)
    p0 = initial_walkers(problem, problem.parameters.initial, 40, rng=rng)
    res = run_ensemble(problem, p0, options=opts, seed=seed)
    z, _ = res.kept()
    step = max(1, int(np.ceil(3 * np.max(res.tau) / res.store_thin)))  # ~independent draws
    return problem.coordinates.from_unconstrained(z[::step].reshape(-1, problem.ndim))


def test_prior_marginals_through_the_sampler_in_creep_coordinates_pass_ks():
    problem = prior_only_problem(_pars().specs)
    problem.coordinates = _creep(problem.parameters)
    x = _prior_draws(problem, 21)
    assert x.shape[0] > 400
    for j, spec in enumerate(problem.parameters.sampled):
        p = stats.kstest(x[:, j], spec.prior_dist.cdf).pvalue
        assert p > 1e-3, (spec.name, p)


def test_ks_catches_a_missing_jacobian_factor(monkeypatch):
    """Negative control: without the gamma (1 - gamma) factor the gamma marginal is wrong."""
    problem = prior_only_problem(_pars().specs)
    coords = _creep(problem.parameters)
    original = CreepCoordinates.log_abs_det_jacobian

    def without_gamma(self, z):
        gam = self.from_unconstrained(z)[..., self.slots[3]]
        with np.errstate(divide="ignore", invalid="ignore"):
            return original(self, z) - np.log(gam * (1 - gam))

    monkeypatch.setattr(CreepCoordinates, "log_abs_det_jacobian", without_gamma)
    problem.coordinates = coords
    x = _prior_draws(problem, 22)
    assert stats.kstest(x[:, 3], problem.parameters.sampled[3].prior_dist.cdf).pvalue < 1e-6


def test_creep_coordinates_need_the_law_sampled_and_mechanics():
    with pytest.raises(ValueError, match="creep coordinates: expected mu, kappa and the fibre law"):
        _creep(paper_parameter_set().updated(fixed=["mu"]))
    with pytest.raises(ValueError, match="reference stretch: expected a stretch > 1"):
        CreepCoordinates(_pars(), stretch=1.0, phi_matrix=0.4, fibres=[(0.2, (1, 0, 0))])
    with pytest.raises(ValueError, match="creep coordinates: expected a family stretched along x"):
        CreepCoordinates(_pars(), stretch=1.5, phi_matrix=0.4, fibres=[(0.2, (0, 1, 0))])
    problem = prior_only_problem(_pars().specs)
    with pytest.raises(
        ValueError, match="sampler coordinates: expected 'box' or 'ramp' for a problem without geometry"
    ):
        coordinate_factory("creep")
    with pytest.raises(ValueError, match="sampler coordinates: expected one of"):
        coordinate_factory("polar")
    with pytest.raises(ValueError, match="sampler coordinates: expected 'box' or a coordinate factory"):
        make_coordinates("creep", problem)
    assert make_coordinates(coordinate_factory("box"), problem) is problem.parameters
    with pytest.raises(ValueError, match="ramp coordinates: expected mu, kappa and the fibre law"):
        make_coordinates(
            coordinate_factory("ramp"), prior_only_problem(paper_parameter_set().updated(fixed=["mu"]).specs)
        )


def test_config_builds_a_tied_problem_in_creep_coordinates():
    from bayestissue.mechanics import load_experiment
    from bayestissue.workflows import build_problem, config_from_mapping

    exp = load_experiment(Path(__file__).resolve().parents[2] / "data" / "T1.toml")
    cfg = config_from_mapping({"parameters": {"tied": TIED}, "sampler": {"coordinates": "creep"}})
    problem = build_problem([exp], cfg)
    assert isinstance(problem.coordinates, CreepCoordinates)
    assert problem.names == ("mu", "kappa", "ginf1", "gamma1", "beta1", "ginf2", "gamma2", "beta2", "sigma_T1")
    assert reference_stretch([exp]) == pytest.approx(1 + exp.displacement_mm.mean() / 5.33)
    assert problem.coordinates.stretch == reference_stretch([exp])
    theta = np.array([[2.18, 2.91, 125, 0.75, 1.25, 13.4, 0.891, 5e-4, 0.02]])
    z = problem.coordinates.to_unconstrained(theta)
    expected = problem.log_posterior(theta) + problem.coordinates.log_abs_det_jacobian(z)
    np.testing.assert_allclose(problem.log_posterior_unconstrained(z), expected, rtol=1e-12)
    full = problem.material_full(theta)[0]
    assert full[8] == full[5] and full[9] == full[6] and full[10] == full[7]


def test_shear_round_trips_and_keeps_the_log_jacobian():
    from bayestissue.inference.coordinates import ShearedCoordinates

    pars = _pars(fix_fibre1=False)
    base = _creep(pars)
    s = base.slots
    grid = np.linspace(-5, 5, 7)
    offsets = np.column_stack([np.sin(grid), 0.1 * grid**2, np.tanh(grid), -0.2 * grid])
    coords = ShearedCoordinates(base, s[0], s[1:], grid, offsets)
    theta = pars.sample_prior(30, rng=np.random.default_rng(5))
    z = coords.to_unconstrained(theta)
    np.testing.assert_allclose(coords.from_unconstrained(z), theta, rtol=1e-9)
    zb = base.to_unconstrained(theta)
    inside = np.abs(zb[:, s[0]]) < 5
    assert np.any(inside) and not np.allclose(z[inside], zb[inside])
    for zi in z[:8]:
        assert coords.log_abs_det_jacobian(zi[None])[0] == pytest.approx(_fd_log_det(coords, zi), abs=1e-5)
    with pytest.raises(ValueError, match="shear offsets: expected finite values of shape"):
        ShearedCoordinates(base, s[0], s[1:], grid, offsets[:, :2])


def test_two_dimensional_shear_round_trips_and_keeps_the_log_jacobian():
    """The shift over (split, share) is a cubic spline: any smooth shift keeps the Jacobian exact."""
    from bayestissue.inference.coordinates import ShearedCoordinates

    pars = _pars(fix_fibre1=False)
    base = _creep(pars)
    s = base.slots
    g0, g1 = np.linspace(-8, 8, 9), np.linspace(-6, 6, 7)
    x, y = np.meshgrid(g0, g1, indexing="ij")
    offsets = np.stack([np.sin(x) * np.cos(y), 0.05 * x * y, np.tanh(x - y)], axis=-1)
    coords = ShearedCoordinates(base, s[:2], s[2:], [g0, g1], offsets)
    theta = pars.sample_prior(30, rng=np.random.default_rng(6))
    z = coords.to_unconstrained(theta)
    np.testing.assert_allclose(coords.from_unconstrained(z), theta, rtol=1e-9)
    zb = base.to_unconstrained(theta)
    np.testing.assert_array_equal(z[:, s[:2]], zb[:, s[:2]])  # the free coordinates are not moved
    assert not np.allclose(z[:, s[2:]], zb[:, s[2:]])
    for zi in z[:8]:
        assert coords.log_abs_det_jacobian(zi[None])[0] == pytest.approx(_fd_log_det(coords, zi), abs=1e-5)
    with pytest.raises(ValueError, match="shear grids: expected one grid per free coordinate"):
        ShearedCoordinates(base, s[:2], s[2:], [g0], offsets)


def test_config_rejects_unknown_coordinates():
    from bayestissue.workflows import config_from_mapping

    expected = "configuration \\[sampler\\] coordinates: expected one of \\['box', 'creep', 'ramp'\\], got 'polar'"
    with pytest.raises(ValueError, match=expected):
        config_from_mapping({"sampler": {"coordinates": "polar"}})


def test_ramp_shear_straightens_the_t2_valley_with_a_unit_jacobian():
    """The ``ramp`` coordinates on the T2 replica: the sheared map round-trips, adds nothing to the
    log-Jacobian (triangular, unit diagonal), and the least-squares optimum of (ginf2, kappa) at
    fixed (gamma2, beta2), fitted here independently, lands on the same dependent coordinates
    wherever (gamma2, beta2) is, while in box coordinates it moves (the curved valley)."""
    from scipy.optimize import least_squares

    from bayestissue.inference import fit_least_squares
    from bayestissue.inference.coordinates import ShearedCoordinates, adapt_coordinates
    from bayestissue.mechanics import load_experiment
    from bayestissue.workflows import build_problem, config_from_mapping
    from bayestissue.workflows.coordinates import RampCoordinates

    exp = load_experiment(Path(__file__).resolve().parents[2] / "data" / "T2.toml")
    cfg = config_from_mapping({"parameters": {"tied": TIED}, "sampler": {"coordinates": "ramp"}})
    problem = build_problem([exp], cfg)
    assert isinstance(problem.coordinates, RampCoordinates)
    ls = fit_least_squares(problem, space="unit", max_nfev=400)
    theta_hat = problem.nuisance_estimate(ls.x)
    coords = adapt_coordinates(problem, theta_hat)
    assert isinstance(coords, ShearedCoordinates)
    box = problem.parameters
    theta = box.sample_prior(20, rng=np.random.default_rng(4))
    z = coords.to_unconstrained(theta)
    np.testing.assert_allclose(coords.from_unconstrained(z), theta, rtol=1e-9)
    np.testing.assert_allclose(coords.log_abs_det_jacobian(z), box.log_abs_det_jacobian(box.to_unconstrained(theta)))

    names = problem.names
    free = [names.index("gamma2"), names.index("beta2")]
    dep = [names.index("ginf2"), names.index("kappa")]
    zb_hat = box.to_unconstrained(theta_hat[None])[0]

    def profile_point(zg, zbeta):
        def resid(q):
            zb = zb_hat.copy()
            zb[free], zb[dep] = (zg, zbeta), q
            return problem.residuals(box.from_unconstrained(zb[None])[:, : problem.n_material])[0]

        zb = zb_hat.copy()
        zb[free] = (zg, zbeta)
        zb[dep] = least_squares(resid, zb_hat[dep], method="lm").x
        return zb

    points = [profile_point(zg, zbeta) for zg, zbeta in [(-2.0, -1.0), (0.5, 1.5), (-0.5, 2.5), (-3.0, 0.0)]]
    z_sheared = coords.to_unconstrained(box.from_unconstrained(np.array(points)))[:, dep]
    z_box = np.array(points)[:, dep]
    z_ref = coords.to_unconstrained(theta_hat[None])[0, dep]
    # in box coordinates the optimum of z_ginf2 moves by about a third of its posterior's 90 % range
    # (0.46 to 0.68; measured 0.067); after the shear it stays put up to the spline's error between
    # nodes 0.3 apart (measured 6e-6)
    spread = np.ptp(z_box, axis=0)
    assert spread[0] > 0.05
    assert np.max(np.abs(z_sheared - z_ref)) < 1e-3


def test_unconverged_runs_in_physics_coordinates_are_pointed_to_the_box():
    """The emcee SBC's stuck ramp fits (docs/verification.md): a NOT CONVERGED run in ramp coordinates is told to try
    the box (and the nested check); a converged run, one in the box or in creep coordinates (which cure the box's
    failure on creep) is told nothing."""
    line = coordinate_advice("ramp", converged=False)
    assert "the ramp coordinates" in line and 'coordinates = "box"' in line and "cross_check" in line
    for kind, converged in (("ramp", True), ("creep", False), ("box", False)):
        assert coordinate_advice(kind, converged=converged) is None

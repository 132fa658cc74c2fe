"""The real-model wiring: residuals, specimen-level forwards, rate scenarios, replicate pooling."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.analyses.propagate import (
    half_angles_deg,
    interval_width,
    pool_draws,
    replicate_tissues,
    width_ratio,
)
from bayestissue.analyses.scenarios import ramp_scenario, synthetic_replica
from bayestissue.mechanics import PAPER_TISSUE, load_experiment, simulate
from bayestissue.paper import PAPER_HALF_ANGLE_DEG, PAPER_PARAMETERS
from bayestissue.workflows import (
    CalibrationConfig,
    ExperimentResiduals,
    SpecimenForward,
    build_problem,
    specimen_spec,
)
from bayestissue.workflows.forward import tissue_with_half_angle

DATA = Path(__file__).resolve().parents[2] / "data"
P1 = np.asarray(PAPER_PARAMETERS["T1"])


@pytest.fixture(scope="module")
def t2():
    return load_experiment(DATA / "T2.toml")


def test_residuals_vanish_on_noise_free_replica(t2):
    exp = synthetic_replica(t2, P1, sd=1e-12, rng=0)
    r = ExperimentResiduals((exp,))
    assert np.max(np.abs(r(P1))) < 10  # noise of 1e-12 scaled by 1e-12
    assert r(np.tile(P1, (3, 1))).shape == (3, t2.time_s.size)
    assert np.max(np.abs(r.predict(P1) - simulate(t2, P1))) == 0


def test_specimen_scale_and_angle_forwards(t2):
    base = simulate(t2, P1)
    f_none = SpecimenForward(t2)
    np.testing.assert_array_equal(f_none(np.append(P1, 3.0))[0], base)
    f_scale = SpecimenForward(t2, "scale")
    np.testing.assert_allclose(f_scale(np.append(P1, 1.0))[0], base, rtol=1e-12)
    # scaling every modulus by s is the same as dividing the load by s (stress is linear in the moduli)
    soft = f_scale(np.append(P1, 0.5))[0]
    assert np.all(soft[1:] > base[1:])
    f_angle = SpecimenForward(t2, "angle")
    np.testing.assert_allclose(f_angle(np.append(P1, PAPER_HALF_ANGLE_DEG))[0], base, atol=1e-9)
    steep = f_angle(np.append(P1, 45.0))[0]
    assert np.all(steep[-10:] > base[-10:])  # fibres further from the load axis: softer
    tis = tissue_with_half_angle(PAPER_TISSUE, 30.0)
    assert half_angles_deg(tis.directions)[0] == pytest.approx(30.0)
    with pytest.raises(ValidationError, match="kind"):
        SpecimenForward(t2, "twist")
    with pytest.raises(ValidationError, match="specimen parameter kind"):
        specimen_spec("twist")


def test_build_problem_with_specimen_parameter(t2):
    prob = build_problem((t2,), CalibrationConfig(noise_options={"sd": "data"}, specimen=("scale", "T2")))
    assert prob.names[-1] == "scale" and prob.ndim == 12
    assert np.isfinite(prob.log_posterior(np.append(P1, 1.0)))
    with pytest.raises(ValidationError, match="specimen target"):
        build_problem((t2,), CalibrationConfig(noise_options={"sd": "data"}, specimen=("scale", "T1")))


def test_ramp_scenario_reproduces_template_and_scales_time(t2):
    same = ramp_scenario(t2, 1.0)
    np.testing.assert_allclose(same.time_s, t2.time_s)
    np.testing.assert_allclose(simulate(same, P1), simulate(t2, P1), rtol=1e-12)
    fast = ramp_scenario(t2, 10.0)
    assert fast.time_s.size == t2.time_s.size
    ramp = t2.time_s[-1] - t2.protocol.hold_s
    assert fast.time_s[-1] - t2.protocol.hold_s == pytest.approx(ramp / 10)
    # same peak stress
    assert fast.nominal_stress_kpa()[-1] == pytest.approx(t2.nominal_stress_kpa()[-1], rel=1e-9)
    with pytest.raises(ValidationError, match="rate_factor"):
        ramp_scenario(t2, 0.0)
    t1 = load_experiment(DATA / "T1.toml")
    with pytest.raises(ValidationError, match="RampProtocol"):
        ramp_scenario(t1, 2.0)


def test_synthetic_replica_noise_level(t2):
    exp = synthetic_replica(t2, P1, sd=0.02, rng=1)
    resid = exp.displacement_mm - simulate(t2, P1)
    assert np.std(resid) == pytest.approx(0.02, rel=0.15)
    assert exp.synthetic and exp.noise_sd_mm == 0.02
    with pytest.raises(ValidationError, match="sd"):
        synthetic_replica(t2, P1, sd=0.0)


def test_replicate_tissues_and_pooling():
    rng = np.random.default_rng(0)
    D = np.repeat(np.asarray(PAPER_TISSUE.directions)[None], 4, axis=0)
    reps = {"directions": D, "phi_fibres": np.full((4, 3), 0.2), "phi_matrix": np.full(4, 0.4)}
    tis = replicate_tissues(reps, base=PAPER_TISSUE)
    assert len(tis) == 4 and tis[0].phi_matrix == pytest.approx(0.4)
    np.testing.assert_allclose(half_angles_deg(D), PAPER_HALF_ANGLE_DEG)
    with pytest.raises(ValidationError, match="replicates"):
        replicate_tissues({"directions": D}, base=PAPER_TISSUE)
    # mixture of N(-1, 1) and N(1, 1): variance 2, width ratio sqrt(2)-ish against N(0, 1)
    a = rng.normal(-1, 1, (20000, 1))
    b = rng.normal(1, 1, (20000, 1))
    pooled = pool_draws([a, b], rng=1)
    assert pooled.shape == (40000, 1)
    assert np.var(pooled) == pytest.approx(2.0, rel=0.05)
    base = rng.normal(0, 1, (20000, 1))
    assert width_ratio(base, pooled)[0] == pytest.approx(interval_width(pooled)[0] / (2 * 1.6449), rel=0.05)
    with pytest.raises(ValidationError, match="draws"):
        pool_draws([])
    with pytest.raises(ValidationError, match="n_per"):
        pool_draws([a], n_per=10**6)
    with pytest.raises(ValidationError, match="level"):
        interval_width(a, level=2)


def test_replicate_tissue_rejects_bad_fraction_sum():
    reps = {
        "directions": np.asarray(PAPER_TISSUE.directions)[None],
        "phi_fibres": np.array([[0.2, 0.2, 0.2]]),
        "phi_matrix": np.array([0.5]),
    }
    tis = replicate_tissues(reps, base=PAPER_TISSUE)  # renormalised to sum 1
    assert tis[0].phi_matrix + tis[0].phi_fibres.sum() == pytest.approx(1.0)
    assert replace(tis[0]).bulk_kpa == PAPER_TISSUE.bulk_kpa


def test_drop_stuck_draws_removes_far_tail_only():
    from bayestissue.workflows import CalibrationDraws, drop_stuck_draws

    rng = np.random.default_rng(3)
    draws = rng.uniform(size=(1000, 11))
    ll = -0.5 * rng.chisquare(11, size=1000)  # a healthy posterior: 2(max - ll) ~ chi2_11
    ll[:7] = -1e5  # seven draws of stuck walkers
    o = CalibrationDraws(
        "x",
        tuple("abcdefghijk"),
        np.zeros(11),
        np.ones(11),
        np.ones(11),
        1.0,
        np.ones(1),
        np.zeros(11),
        draws=draws,
        u=draws,
        loglik=ll[:, None],
    )
    c = drop_stuck_draws(o)
    assert c.n_dropped == 7 and c.draws.shape[0] == 993
    assert o.draws.shape[0] == 1000  # the input is not modified


@pytest.mark.slow
def test_run_calibration_end_to_end_on_a_replica(t2):
    from bayestissue.workflows import CalibrationTask, run_task

    p2 = np.asarray(PAPER_PARAMETERS["T2"])
    exp = synthetic_replica(t2, p2, sd=0.02, rng=5)
    task = CalibrationTask(
        (exp,), n_starts=0, paper_start=False, extra_starts=(tuple(p2),), n_steps=80, n_ensembles=2, keep=500, seed=1
    )
    o = run_task(task)
    # chi2 at the optimum: about n_obs - n_informed (143 - 3), certainly within 4 sd of chi2_143
    assert 80 < o.ls_chi2 < 143 + 4 * np.sqrt(2 * 143)
    assert o.draws.shape[1] == 11 and o.u.min() >= 0 and o.u.max() <= 1
    assert o.loglik.shape == (o.draws.shape[0], 1)


def test_tied_least_squares_reports_all_11_and_attach_posterior_expands_ties(t2, tmp_path):
    import arviz as az

    from bayestissue.io.results import write_inference_data
    from bayestissue.paper import MIRROR_TIES
    from bayestissue.workflows import CalibrationTask, attach_posterior, paper_parameter_set, run_task

    p2 = np.asarray(PAPER_PARAMETERS["T2"])
    exp = synthetic_replica(t2, p2, sd=0.02, rng=5)
    task = CalibrationTask(
        (exp,), n_starts=0, paper_start=False, extra_starts=(tuple(p2),), n_steps=0, max_nfev=15, tied=MIRROR_TIES
    )
    ls = run_task(task)
    names = paper_parameter_set().names
    assert ls.names == names and ls.ls_x.shape == (11,)
    for a, b in MIRROR_TIES:  # the tied parameter reports its target's estimate
        assert ls.ls_x[names.index(a)] == ls.ls_x[names.index(b)]
    # a results file of the mirror model: 8 material parameters + a noise sd, 4 chains x 50 draws
    mirror = paper_parameter_set().updated(tied=dict(MIRROR_TIES))
    rng = np.random.default_rng(0)
    theta = mirror.from_unit(rng.uniform(0.2, 0.8, size=(200, 8))).reshape(4, 50, 8)
    post = {n: theta[..., j] for j, n in enumerate(mirror.sampled_names)}
    post["sigma_T2"] = np.full((4, 50), 0.02)
    ll = rng.normal(size=(4, 50, exp.time_s.size))
    idata = az.from_dict(posterior=post, log_likelihood={"T2": ll})
    for j, n in enumerate(mirror.sampled_names):  # as to_inference_data stores them: per variable, typed
        idata.posterior[n].attrs["rhat_ensembles"] = 1 + j / 1000
    for a, b in MIRROR_TIES:
        idata.posterior[b].attrs.setdefault("tied", []).append(a)
    path = write_inference_data(idata, tmp_path / "post.nc", attrs={"convergence": "CONVERGED: test", "converged": 1})
    o = attach_posterior(ls, path, keep=120)
    assert o.draws.shape == (120, 11) and ls.draws is None  # a copy
    idx = np.unique(np.linspace(0, 199, 120).astype(int))
    flat = theta.reshape(200, 8)[idx]
    for a, b in MIRROR_TIES:
        np.testing.assert_array_equal(o.draws[:, names.index(a)], flat[:, mirror.sampled_names.index(b)])
    np.testing.assert_array_equal(o.draws[:, names.index("mu")], flat[:, 0])
    np.testing.assert_allclose(o.loglik[:, 0], ll.reshape(200, -1).sum(axis=1)[idx])
    np.testing.assert_allclose(o.u, paper_parameter_set().to_unit(o.draws))
    assert o.rhat[names.index("beta3")] == o.rhat[names.index("beta2")] == 1.007
    assert o.tied == dict(MIRROR_TIES) and o.convergence == "CONVERGED: test" and o.converged
    assert o.results_file == "post.nc" and o.fit == {} and not o.misfit  # no predictive draws: nothing checked
    with pytest.raises(ValidationError, match="experiments"):
        attach_posterior(replace(ls, experiment_names=("T1",)), path)


@pytest.mark.slow
def test_replicate_task_uses_the_calibration_sampler(t2):
    """A task with ramp coordinates and mixture moves (the cut posterior's replicate chains) follows the
    T2 replica's curved valley: ginf2 moves with the fibre viscosity (the converged T2 posterior's 90 %
    widths in the scaled box: ginf2 0.117, beta2 0.882); a box-coordinate DE chain of the same length
    stays near its start in ginf2 (measured: 0.002 vs 0.093; beta2 0.32 vs 0.95). An unknown coordinate
    system is refused by name."""
    from bayestissue.analyses.propagate import interval_width
    from bayestissue.paper import MIRROR_TIES
    from bayestissue.workflows import CalibrationTask, paper_parameter_set, run_task

    p2 = np.asarray(PAPER_PARAMETERS["T2"])
    exp = synthetic_replica(t2, p2, sd=0.02, rng=5)
    kw = dict(n_starts=0, paper_start=False, extra_starts=(tuple(p2),), n_steps=400, n_ensembles=1, seed=3)
    kw |= dict(keep=1000, tied=MIRROR_TIES, max_nfev=60, adapt_rounds=1, adapt_steps=200)
    ramp = run_task(CalibrationTask((exp,), coordinates="ramp", moves="mixture", **kw))
    box = run_task(CalibrationTask((exp,), **kw))
    names = paper_parameter_set().names
    w_ramp, w_box = interval_width(ramp.u), interval_width(box.u)
    g, b = names.index("ginf2"), names.index("beta2")
    assert w_ramp[g] > 0.05 and w_ramp[g] > 10 * w_box[g], (w_ramp[g], w_box[g])
    assert w_ramp[b] > 0.7, w_ramp[b]
    assert np.all(np.isfinite(ramp.loglik))
    with pytest.raises(ValidationError, match="coordinates"):
        run_task(CalibrationTask((exp,), coordinates="polar", **kw))


def test_warm_start_without_a_finite_cost_is_refused_by_name():
    """Every least-squares fit failed (NaN costs: e.g. a creep test whose displacements no parameter set in the boxes
    reaches): one message naming the experiments, not a ZeroDivisionError (issue 34)."""
    from types import SimpleNamespace

    from bayestissue._validation import ValidationError
    from bayestissue.workflows import config_from_mapping
    from bayestissue.workflows.calibration import _ensemble_centres
    from tests.inference.linear_model import linear_gaussian_problem

    problem, _ = linear_gaussian_problem()
    fits = [SimpleNamespace(cost=float("nan"), s2=float("nan"), x=np.zeros(problem.ndim), cov=None)] * 3
    with pytest.raises(ValidationError, match=r"least-squares warm start on .*: expected a parameter set in the boxes"
                                              r".*got '3 fits, none with a finite cost'"):  # fmt: skip
        _ensemble_centres(problem, fits, fits[0], config_from_mapping(None))


def test_warm_start_in_the_other_labelling_of_prony_branches():
    """Prony branches are ordered by decreasing rate and cannot be relabelled by a permutation: least-squares optima
    with beta1 < beta1_2 start no ensemble. With none in order the run is refused by name (what to do instead); with
    one in order every ensemble starts there."""
    from types import SimpleNamespace

    from bayestissue.workflows import config_from_mapping, load_config
    from bayestissue.workflows.calibration import _ensemble_centres
    from bayestissue.workflows.problem import build_problem

    root = Path(__file__).resolve().parents[2]
    exp = load_experiment(root / "data" / "synthetic" / "tendon_relaxation.toml")
    problem = build_problem([exp], load_config(root / "examples" / "tendon_relaxation.toml"))
    names = problem.material.sampled_names
    assert problem.parameters.ordered_text == "beta1 > beta1_2"
    x = problem.material.initial.copy()
    slow_first = x.copy()
    slow_first[names.index("beta1")], slow_first[names.index("beta1_2")] = 0.01, 0.3
    other = slow_first.copy()
    other[names.index("k1_1")] *= 2.0  # a second, distinct optimum in the same wrong labelling
    fits = [SimpleNamespace(cost=1.0, s2=1.0, x=v, cov=None) for v in (slow_first, other)]
    config = config_from_mapping(None)
    refused = r"least-squares warm start: expected an optimum in the ordered labelling .*got '2 plausible optima, none"
    with pytest.raises(ValidationError, match=refused):
        _ensemble_centres(problem, fits, fits[0], config)
    fast_first = slow_first.copy()
    fast_first[names.index("beta1")], fast_first[names.index("beta1_2")] = 0.3, 0.01
    fast_first[names.index("k1_1")] *= 4.0
    fits.append(SimpleNamespace(cost=1.5, s2=1.0, x=fast_first, cov=None))
    centres, _ = _ensemble_centres(problem, fits, fits[0], config)
    assert centres.shape[0] == config.sampler.n_ensembles
    assert np.all(problem.parameters.in_order(centres))
    np.testing.assert_allclose(centres[:, : problem.n_material], np.tile(fast_first, (centres.shape[0], 1)))

    from bayestissue.inference.summary import summary_table

    def meta(x):
        nan = np.full(x.size, np.nan)
        ls = SimpleNamespace(x=x, wald_lower=nan, wald_upper=nan, active=np.zeros(x.size, int), cost=1.0, nit=3)
        return summary_table(problem, ls)["meta"]["parameters_ordered"]

    assert meta(fast_first) == "beta1 > beta1_2"
    assert meta(slow_first).startswith("beta1 > beta1_2 (the least-squares optimum is in another labelling")

"""Assemble an arviz ``InferenceData`` from a posterior sample of either engine.

Groups:

* ``posterior``: the sampled parameters (natural units). emcee: one *chain* per walker, ensemble-major
  (``constant_data.ensemble_of_chain`` maps chains to ensembles); R-hat over these chains is **not**
  valid (walkers of one ensemble interact); use
  :func:`bayestissue.inference.diagnostics.rhat_ensembles`. Nested: one chain per run, equal-weight draws
  resampled from the run's importance weights.
* ``sample_stats``: ``lp`` (unnormalised log-posterior, natural units) and, for emcee, ``lp_unconstrained``
  (the sampler's target, with the log-Jacobian).
* ``importance_sample`` (nested only): every run's weighted points (``points``, ``weight`` summing to one over
  all runs, ``run``); the attributes carry the log evidence (``log_evidence``, ``log_evidence_err``, per run
  ``log_evidence_runs``, ``log_evidence_err_runs``, ``n_eff_runs``).
* ``log_likelihood``: pointwise log-likelihood per experiment (for ``az.loo``; for AR(1) noise these
  are the conditional terms of the exact factorisation).
* ``posterior_predictive``: a thinned subset of draws: ``<exp>`` with noise, ``<exp>_model``
  without.
* ``observed_data`` and ``constant_data`` (fixed parameters and inputs, bounds, least-squares
  estimate).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping

import numpy as np

from bayestissue.inference.diagnostics import import_arviz
from bayestissue.inference.likelihood import _tag
from bayestissue.inference.sampling import NestedSample, PosteriorSample

__all__ = ["evenly", "tied_sources", "to_inference_data"]


def evenly(n: int, keep: int) -> np.ndarray:
    """At most ``keep`` evenly spaced indices into ``n`` draws (thinning)."""
    return np.unique(np.linspace(0, n - 1, min(keep, n)).astype(int))


def tied_sources(posterior) -> dict[str, str]:
    """Each tied parameter -> the posterior variable holding its draws (the ``tied`` attribute
    :func:`to_inference_data` writes on the target)."""
    return {str(t): v for v in posterior.data_vars for t in np.atleast_1d(posterior[v].attrs.get("tied", [])).tolist()}


def _numeric_inputs(inputs: Mapping) -> tuple[dict, dict]:
    arrays, text = {}, {}
    for k, v in inputs.items():
        a = np.asarray(v)
        if a.dtype.kind in "biuf" and a.size:
            arrays[_tag(k)] = a.astype(float)
        else:
            text[f"fixed_input:{k}"] = str(v)
    return arrays, text


def to_inference_data(
    sample: PosteriorSample | NestedSample,
    *,
    least_squares=None,
    max_draws: int = 4000,
    n_predictive: int = 400,
    attrs: Mapping | None = None,
    rhat: Mapping[str, float] | None = None,
    rng=None,
):
    """Build the ``InferenceData`` of a :class:`~bayestissue.inference.sampling.PosteriorSample` (emcee) or
    :class:`~bayestissue.inference.sampling.NestedSample`.

    Parameters
    ----------
    sample : PosteriorSample or NestedSample
    least_squares : LeastSquaresResult, optional (stored in ``constant_data``).
    max_draws : cap on the total number of posterior draws kept (further thinning, evenly).
    n_predictive : approximate number of draws in ``posterior_predictive``.
    attrs : global attributes (provenance).
    rhat : between-ensemble (nested: between-run) R-hat per sampled parameter, stored as the variable's
        ``rhat_ensembles`` attribute.
        Each tied parameter is listed in its target variable's ``tied`` attribute (a list of names), so that
        a reader expands the draws without parsing text (``parameters_tied`` keeps the ties readable).
    rng : seed or Generator for the predictive noise.
    """
    az = import_arviz()
    rng = np.random.default_rng(rng)
    problem = sample.problem
    pars = problem.parameters
    if isinstance(sample, NestedSample):
        theta_c, sample_stats, engine_info = _nested_chains(sample, max_draws)
    else:
        theta_c, sample_stats, engine_info = _ensemble_chains(sample, max_draws)
    n_chain, n_d, ndim = theta_c.shape
    theta = theta_c.reshape(-1, ndim)
    posterior = {name: theta_c[:, :, j] for j, name in enumerate(problem.names)}
    preds = problem.predict(theta)
    ll = problem.log_likelihood_pointwise(theta, predictions=preds)
    if not sample_stats:  # nested draws: the log-posterior from the forward pass done here anyway
        total = sum(part.sum(axis=1) for part in ll)
        sample_stats = {"lp": (problem.log_prior(theta) + total).reshape(n_chain, n_d)}
    names = [_tag(e.name) for e in problem.experiments]
    log_lik = {n: l.reshape(n_chain, n_d, -1) for n, l in zip(names, ll, strict=False)}
    dims = {n: [f"time_{n}"] for n in names}
    coords = {f"time_{n}": e.time_s for n, e in zip(names, problem.experiments, strict=False)}
    # thinned posterior predictive: evenly spaced draws in every chain
    k = max(1, min(n_d, round(n_predictive / n_chain)))
    didx = np.unique(np.linspace(0, n_d - 1, k).round().astype(int))
    sel = (np.arange(n_chain)[:, None] * n_d + didx[None, :]).ravel()
    pp = {}
    for i, (n, e) in enumerate(zip(names, problem.experiments, strict=False)):
        mean = preds[i][sel]
        nuis = problem.nuisance(theta[sel], i)
        noisy = mean + e.noise.simulate(mean.shape[1], nuis, rng=rng)
        pp[n] = noisy.reshape(n_chain, didx.size, -1)
        pp[f"{n}_model"] = mean.reshape(n_chain, didx.size, -1)
        dims[f"{n}_model"] = [f"time_{n}"]
    observed = {n: e.observed for n, e in zip(names, problem.experiments, strict=False)}
    arrays, text = _numeric_inputs(problem.material.fixed_inputs)
    constant = {
        **engine_info.pop("constant", {}),
        "lower": pars.lower,
        "upper": pars.upper,
    }
    for s in problem.material.specs:
        if s.fixed:
            constant[f"fixed_{s.name}"] = np.array([s.value])
    for k_, v in arrays.items():
        constant[f"input_{k_}"] = v
    if least_squares is not None:
        constant["least_squares_estimate"] = least_squares.x
        constant["least_squares_sd"] = least_squares.sd
    cdims = {
        "lower": ["parameter"],
        "upper": ["parameter"],
        "ensemble_of_chain": ["chain"],
        "least_squares_estimate": ["material_parameter"],
        "least_squares_sd": ["material_parameter"],
    }
    coords.update(
        parameter=list(problem.names),
        material_parameter=list(problem.material.sampled_names),
        chain=np.arange(n_chain),
    )
    with warnings.catch_warnings():  # "more chains than draws" is expected: chains are walkers
        warnings.filterwarnings("ignore", message="More chains", category=UserWarning)
        idata = az.from_dict(
            posterior=posterior,
            sample_stats=sample_stats,
            log_likelihood=log_lik,
            observed_data=observed,
            constant_data=constant,
            coords=coords,
            dims={**dims, **cdims},
        )
        pp_ds = az.from_dict(posterior_predictive=pp, coords={**coords, "draw": didx}, dims=dims)
    idata.extend(pp_ds)
    importance = engine_info.pop("importance", None)
    if importance is not None:
        idata.add_groups({"importance_sample": importance})
    info = {
        **engine_info,
        "n_failed_forward": sample.n_failed,
        "n_forward_evaluations": sample.n_evaluations,
        "sampling_time_s": float(sample.time_s),
        "parameters_tied": problem.material.tied_text,
        **text,
        **dict(attrs or {}),
    }
    for group in idata.groups():
        getattr(idata, group).attrs.update(info)
    for name, value in (rhat or {}).items():
        idata.posterior[name].attrs["rhat_ensembles"] = float(value)
    for name, target in problem.material.tied.items():
        if target in idata.posterior:  # a tie to a fixed parameter takes its fixed value: nothing sampled to mark
            idata.posterior[target].attrs.setdefault("tied", []).append(name)
    return idata


def _ensemble_chains(sample: PosteriorSample, max_draws: int):
    """emcee: one chain per walker (ensemble-major), thinned evenly to about ``max_draws`` draws in all."""
    problem = sample.problem
    z = sample.kept_z()  # (E, D, W, P)
    lpz = sample.kept_log_prob()  # (E, D, W)
    n_ens, n_d, nw, ndim = z.shape
    keep = min(n_d, max(1, max_draws // (n_ens * nw)))
    rows = np.unique(np.round(np.linspace(0, n_d - 1, keep)).astype(int))
    thin = n_d / rows.size
    z, lpz = z[:, rows], lpz[:, rows]
    n_d = z.shape[1]
    zc = z.transpose(0, 2, 1, 3).reshape(n_ens * nw, n_d, ndim)
    lpzc = lpz.transpose(0, 2, 1).reshape(n_ens * nw, n_d)
    flat_z = zc.reshape(-1, ndim)
    theta = problem.coordinates.from_unconstrained(flat_z).reshape(zc.shape)
    lp_nat = lpzc - problem.coordinates.log_abs_det_jacobian(flat_z).reshape(n_ens * nw, n_d)
    info = {
        "engine": "emcee",
        "n_ensembles": n_ens,
        "walkers_per_ensemble": nw,
        "chains_are": "walkers (ensemble-major); R-hat over chains is not valid, see attrs rhat_*",
        "thin_stored": float(thin),
        "ensemble_seeds": ",".join(str(s) for s in (sample.seeds or [])),
        "sampler_coordinates": type(problem.coordinates).__name__,
        "constant": {"ensemble_of_chain": np.repeat(np.arange(n_ens), nw).astype(float)},
    }
    return theta, {"lp": lp_nat, "lp_unconstrained": lpzc}, info


def _nested_chains(sample: NestedSample, max_draws: int):
    """Nested runs: one chain per run of equal-weight draws (at most ``max_draws`` in all); the weighted points
    of every run go to the ``importance_sample`` group, the evidence to the attributes."""
    import xarray as xr

    draws = sample.draws()
    n_runs = draws.shape[0]
    draws = draws[:, : max(1, max_draws // n_runs)]
    pts, w, run = sample.weighted()
    importance = xr.Dataset(
        {
            "points": (("point", "parameter"), pts),
            "weight": (("point",), w),
            "run": (("point",), run.astype(float)),
        },
        coords={"parameter": list(sample.names)},
    )
    info = {
        "engine": f"nested ({sample.sampler})",
        "n_runs": n_runs,
        "chains_are": "nested runs (equal-weight draws resampled from each run's importance weights)",
        "log_evidence": sample.log_z,
        "log_evidence_err": sample.log_z_err,
        "log_evidence_runs": np.array([r.log_z for r in sample.runs]),
        "log_evidence_err_runs": np.array([r.log_z_err for r in sample.runs]),
        "n_eff_runs": np.array([r.n_eff for r in sample.runs]),
        "run_seeds": ",".join(str(s) for s in (sample.seeds or [])),
        "importance": importance,
    }
    insertion = sample.insertion_tests()
    if insertion is not None:  # UltraNest: the insertion-order test of each run
        info["insertion_test_passed_runs"] = insertion[0].astype(int)
        info["insertion_test_quiet_iterations_runs"] = insertion[1]
    return draws, {}, info

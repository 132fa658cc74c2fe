"""Summary table of a calibration: reference values, least squares, posterior, diagnostics and flags.

One row per sampled parameter. Columns: the paper's Table 1 value and the generating value of a synthetic replica
(when known), the least-squares estimate with its Wald interval, the posterior median, mean, sd and 90 % equal-tailed
interval (the nested engine's median and interval: its runs' weighted quantiles averaged over the runs, the estimate
whose error its report gives), the Monte Carlo error of the 5/50/95 % quantiles (``mcse_q05``, ``mcse_median``,
``mcse_q95``: the nested engine's from its runs' bootstraps, :mod:`~bayestissue.inference.evidence`; the ensembles'
from their ESS, :func:`~bayestissue.inference.diagnostics.quantile_mcse`), bulk and tail ESS, between-ensemble R-hat,
the *contraction*

.. math:: c = 1 - \\frac{\\operatorname{Var}_{\\text{post}}(u)}{\\operatorname{Var}_{\\text{prior}}(u)}

in the scaled box coordinates :math:`u` (Betancourt 2018, arXiv:1803.08393; :math:`c \\approx 0`:
the data do not inform the parameter), and flags:

* ``ls_outside_90``: least-squares estimate outside the posterior 90 % interval;
* ``bound_active_lower`` / ``bound_active_upper``: active bound at the least-squares optimum;
* ``piled_lower`` / ``piled_upper``: more than 10 % of the posterior mass in the outermost 2 % of
  the scaled box (a posterior piled against a bound);
* ``prior_dominated``: contraction below 0.3;
* ``not_converged``: R-hat >= 1.01 or bulk/tail ESS < 400.
"""

from __future__ import annotations

import math

import numpy as np

from bayestissue._validation import ValidationError

__all__ = ["PRIOR_DOMINATED_CONTRACTION", "draw_log_likelihood", "generating_fit", "summary_table", "table_markdown"]

#: A parameter is prior-dominated below this contraction: its posterior variance is more than 70 % of the prior's
#: in the scaled box (the study's "informed" rule, bayestissue.analyses.verdicts.informed, is its complement).
PRIOR_DOMINATED_CONTRACTION = 0.3
_EDGE, _PILE = 0.02, 0.10


def _ref_columns(problem, references) -> dict[str, np.ndarray]:
    names = problem.names
    mat_names = problem.material.names
    cols = {}
    for exp, refs in (references or {}).items():
        suffix = "" if len(references) == 1 else f"_{exp}"
        for kind in ("paper", "generating"):
            if kind not in refs:
                continue
            vals = dict(zip(mat_names, np.asarray(refs[kind], dtype=float), strict=False))
            if kind == "generating" and "noise_sd" in refs:
                vals[f"sigma_{exp}"] = float(refs["noise_sd"])
            cols[f"{kind}{suffix}"] = np.array([vals.get(n, np.nan) for n in names])
    return cols


def summary_table(problem, least_squares, sample=None, report=None, *, references=None) -> dict:
    """Build the summary table.

    Parameters
    ----------
    problem : CalibrationProblem
    least_squares : LeastSquaresResult of the material parameters (the warm start).
    sample : PosteriorSample or None (least-squares columns only).
    report : ConvergenceReport or NestedReport (both :class:`~bayestissue.inference.diagnostics.ParameterChecks`), or
        None.
    references : mapping experiment -> {"paper": (11,), "generating": (11,), "noise_sd": float}.

    Returns
    -------
    dict with ``columns`` (name -> 1-D array, for :func:`bayestissue.io.tables.write_table`) and
    ``meta``.
    """
    names = problem.names
    n = len(names)
    m = problem.n_material
    pars = problem.parameters
    nan = np.full(n, np.nan)
    cols: dict[str, np.ndarray] = {
        "parameter": np.array(names, dtype=str),
        "unit": np.array([s.unit for s in pars.sampled], dtype=str),
        "prior": np.array([s.prior for s in pars.sampled], dtype=str),
        "lower": pars.lower,
        "upper": pars.upper,
    }
    cols.update(_ref_columns(problem, references))
    nuis = problem.nuisance_estimate(least_squares.x)
    ls = nuis.copy()
    wl, wu = nan.copy(), nan.copy()
    wl[:m], wu[:m] = least_squares.wald_lower, least_squares.wald_upper
    cols["ls_estimate"] = ls
    cols["wald_lower_90"], cols["wald_upper_90"] = wl, wu
    active = np.zeros(n, dtype=int)
    active[:m] = least_squares.active
    perm = problem.parameters.relabelling(ls)  # report the LS optimum in the draws' labelling
    if getattr(problem, "exchangeable", None) is not None:
        a_idx, b_idx = problem.exchangeable
        if ls[perm][a_idx[0]] < ls[perm][b_idx[0]]:
            perm[a_idx], perm[b_idx] = perm[b_idx].copy(), perm[a_idx].copy()
    ls, wl, wu, active = ls[perm], wl[perm], wu[perm], active[perm]
    cols["ls_estimate"] = ls
    cols["wald_lower_90"], cols["wald_upper_90"] = wl, wu
    flags = [[] for _ in range(n)]
    for j, a in enumerate(active):
        if a:
            flags[j].append("bound_active_lower" if a < 0 else "bound_active_upper")
    meta = {
        "parameters_fixed": ", ".join(f"{s.name}={s.value:g}" for s in problem.material.specs if s.fixed) or "none",
        "parameters_tied": problem.material.tied_text,
        "least_squares_cost": f"{least_squares.cost:.6g}",
        "least_squares_iterations": least_squares.nit,
    }
    if problem.material.ordered:  # the labelling the prior keeps (inference.ordering.OrderedGroup)
        meta["parameters_ordered"] = problem.material.ordered_text
        if not problem.parameters.in_order(ls):  # Prony branches: no permutation brings it into the draws' labelling
            meta["parameters_ordered"] += (" (the least-squares optimum is in another labelling: its ls_estimate and "
                                           "Wald columns describe other branches than the draws')")  # fmt: skip
    if sample is not None:
        flat = sample.flat()
        q05, q50, q95 = np.quantile(flat, [0.05, 0.5, 0.95], axis=0) if report is None else report.quantiles(flat).T
        cols.update(median=q50, mean=flat.mean(axis=0), sd=flat.std(axis=0, ddof=1), q05=q05, q95=q95)
        u_post = pars.to_unit(flat)
        u_prior = pars.to_unit(pars.sample_prior(20000, rng=0))
        contraction = 1.0 - u_post.var(axis=0) / u_prior.var(axis=0)
        cols["contraction"] = contraction
        lo_mass = np.mean(u_post < _EDGE, axis=0)
        hi_mass = np.mean(u_post > 1 - _EDGE, axis=0)
        for j in range(n):
            if not (q05[j] <= ls[j] <= q95[j]):
                flags[j].append("ls_outside_90")
            if lo_mass[j] > _PILE:
                flags[j].append("piled_lower")
            if hi_mass[j] > _PILE:
                flags[j].append("piled_upper")
            if contraction[j] < PRIOR_DOMINATED_CONTRACTION:
                flags[j].append("prior_dominated")
    if report is not None:
        cols.update(ess_bulk=report.ess_bulk, ess_tail=report.ess_tail, rhat=report.rhat)
        if sample is not None:
            mc = report.quantile_errors(flat)
            cols.update(mcse_q05=mc[:, 0], mcse_median=mc[:, 1], mcse_q95=mc[:, 2])
        for j in np.flatnonzero(~report.parameters_ok):
            flags[j].append("not_converged")
        meta["convergence"] = report.verdict()
        meta["sampling_time_s"] = f"{report.time_s:.1f}"
        meta["ess_per_s_min"] = f"{report.ess_per_second():.2f}"
    if sample is not None and sample.n_evaluations:
        n_f, n_e = sample.n_failed, sample.n_evaluations
        meta["failed_forward_solves"] = (f"{n_f} of {n_e} evaluations ({100.0 * n_f / n_e:.2g} %): parameter sets "
                                         "the solver could not follow (zero likelihood)")  # fmt: skip
    cols["flags"] = np.array([";".join(f) or "-" for f in flags], dtype=str)
    return {"columns": cols, "meta": meta}


def draw_log_likelihood(idata) -> np.ndarray:
    """Total log-likelihood of every stored draw (``(chain * draw,)``): the pointwise ``log_likelihood`` group summed
    over its experiments and observations."""
    total = sum(da.sum([d for d in da.dims if d not in ("chain", "draw")]) for da in idata.log_likelihood.values())
    return np.asarray(total, dtype=float).ravel()


def generating_fit(problem, idata, theta) -> dict[str, float]:
    """How well ``theta`` (e.g. a replica's generating values, all of ``problem.names`` including the
    noise parameters) fits the data, next to the posterior draws stored in ``idata``.

    Returns the total log-likelihood :math:`\\log p(y \\mid \\theta)` (``log_lik``), the 5 %, 95 % and
    largest total log-likelihood of the stored draws (``q05``, ``q95``, ``max``; summed over the
    pointwise ``log_likelihood`` group), and the share of draws ``theta`` beats (``share_below``).

    It tells the two readings of a generating value outside a 90 % interval apart: a log-likelihood
    inside the draws' range means the data do not exclude ``theta`` (the interval misses it through
    the prior's weight along a flat direction, or an unconverged chain); one far below means they do.
    For a correct posterior of data simulated from the prior, ``theta`` and a posterior draw are
    exchangeable, so ``share_below`` is uniform over replicas (Talts et al. 2018, arXiv:1804.06788).
    """
    theta = problem.canonical(np.atleast_2d(np.asarray(theta, dtype=float)))
    if theta.shape != (1, problem.ndim):
        raise ValidationError("theta", f"shape {theta.shape}", f"{problem.ndim} values ({', '.join(problem.names)})")
    ll_theta = float(problem.log_likelihood(theta)[0])
    ll = draw_log_likelihood(idata)
    q05, q95 = np.percentile(ll, [5, 95])
    return {
        "log_lik": ll_theta,
        "q05": float(q05),
        "q95": float(q95),
        "max": float(ll.max()),
        "share_below": float(np.mean(ll < ll_theta)),
    }


def _fmt(v) -> str:
    if isinstance(v, str | np.str_):
        return str(v)
    v = float(v)
    if math.isnan(v):
        return ""
    if v != 0 and (abs(v) >= 1e4 or abs(v) < 1e-3):
        return f"{v:.3e}"
    return f"{v:.4g}"


def table_markdown(table: dict, *, title: str | None = None) -> str:
    """Render :func:`summary_table` output as a Markdown table (meta entries as a bullet list below)."""
    cols = table["columns"]
    keys = [k for k in cols if k not in ("lower", "upper", "prior")]
    lines = []
    if title:
        lines += [f"# {title}", ""]
    lines.append("| " + " | ".join(keys) + " |")
    lines.append("|" + "|".join("---" for _ in keys) + "|")
    for i in range(len(cols["parameter"])):
        lines.append("| " + " | ".join(_fmt(cols[k][i]) for k in keys) + " |")
    lines.append("")
    for k, v in table.get("meta", {}).items():
        lines.append(f"- {k}: {v}")
    return "\n".join(lines) + "\n"

"""The calibration study's settings and its recovery report (``studies/calibrate.py``).

Settings per budget (``quick``, ``default``, ``full``) and model (``full``: the paper's 11 parameters with families
2/3 folded; ``mirror``: family 3 tied to family 2's law), each with the measurement that chose it; and the lines of
``calibration_recovery.md``: do the 90 % intervals contain the generating values, which parameters are informed,
and do the data exclude the generating values (:func:`~bayestissue.inference.summary.generating_fit`)?
"""

from __future__ import annotations

import numpy as np

from bayestissue.analyses import verdicts
from bayestissue.analyses.records import CalibrationRun, ParameterRow, TissueTermsRecord
from bayestissue.inference.summary import draw_log_likelihood, generating_fit
from bayestissue.paper import MIRROR_TIES

__all__ = [
    "FULL_SAMPLER",
    "MIRROR_ADAPT",
    "MIRROR_CAPS",
    "MIRROR_COORDINATES",
    "MIRROR_SAMPLER",
    "MODELS",
    "BUDGETS",
    "SEED",
    "calibration_run",
    "generating_cost",
    "generating_line",
    "mirror_coordinates",
    "recovery_lines",
    "study_config",
    "tissue_terms_record",
]

SEED = 20261121
#: Fibre families 2 and 3 are mirror images about the loading axis: exchanging their parameters leaves the
#: displacement unchanged, so the posterior has two label-switched copies of every mode. The study restricts
#: the prior to ginf2 >= ginf3 (CalibrationConfig.exchangeable) to remove the duplicate.
MIRROR = [["ginf2", "gamma2", "beta2"], ["ginf3", "gamma3", "beta3"]]
#: The mirror-symmetric model: family 3 takes family 2's law (8 material parameters), sampled in the
#: creep-curve coordinates with profile shears (bayestissue.inference.coordinates). The displacement
#: cannot tell the two families apart, and in the paper's parameters the posterior is an L in
#: (log mu, log kappa) joined to a thin curved ridge that emcee cannot cross in the step budget.
TIED = dict(MIRROR_TIES)
MODELS = {
    "full": {"exchangeable": MIRROR},
    "mirror": {"tied": TIED, "coordinates": "creep"},
}
#: Sampler settings of the mirror model per mode: 4 ndim walkers (the issue's default) and half of the moves
#: independence proposals from a Student-t mixture fitted during discarded adaptation steps
#: (bayestissue.inference.proposals); the automatic length stops the run once the verdict's length criterion holds.
#: Measured on T1 (benchmarks/bench_sampling.py, 36 walkers): adaptation 3 x 1000 -> 198 s to the verdict,
#: 2 x 500 -> 120 s (both converged); 20 walkers instead of 36: one ensemble ran to the cap (tau 457).
MIRROR_SAMPLER = {
    "quick": {"moves": "mixture", "adapt_rounds": 1, "adapt_steps": 60},
    "default": {"n_walkers": None, "moves": "mixture", "max_steps": 6000, "adapt_rounds": 2, "adapt_steps": 500},
    "full": {"n_walkers": None, "moves": "mixture"},
}

#: Sampler settings of the 11-parameter model per mode: fitted-mixture moves with one proposal shared by the four
#: ensembles (SamplerOptions.proposal = "shared"), so that an ensemble can jump into a mode another one found.
#: Measured at the default budget (26 walkers, 2000 steps, seed SEED): DE/snooker moves left one T1 ensemble in a
#: second mode (R-hat 1.955) and two T2 ensembles in lower modes (R-hat 1.974; 2.199 with per-ensemble mixtures); a
#: shared mixture brought all four ensembles together (max R-hat 1.108 on T1, 1.084 on T2), still NOT CONVERGED:
#: within a mode tau is 200 steps at 2000 and grew to 2700-2900 at 30 000 (48 walkers, creep coordinates, 36 min).
FULL_SAMPLER = {
    "quick": {"moves": "mixture", "proposal": "shared", "adapt_rounds": 1, "adapt_steps": 60},
    "default": {"moves": "mixture", "proposal": "shared", "adapt_rounds": 2, "adapt_steps": 500},
    "full": {"moves": "mixture", "proposal": "shared"},
}

#: Step caps of the default mirror runs, aiming at the 20-minute study budget: T1 meets the length criterion
#: between about 3400 and 9000 steps (one ensemble was still short at 6000); T2 (ramp coordinates) after 2100-3900
#: steps; the joint run (ramp coordinates, 3 x 1000 adaptation) after 5400-6300 steps.
MIRROR_CAPS = {"T1": 9000, "T2": 6000, "joint": 9000}
#: Mixture adaptation of the default mirror runs where it differs from MIRROR_SAMPLER (see above).
MIRROR_ADAPT = {"joint": {"adapt_rounds": 3, "adapt_steps": 1000}}

BUDGETS = {
    "quick": {
        "n_starts": 1,
        "ls_max_nfev": 100,
        "sampler": {
            "n_walkers": 26,
            "n_ensembles": 2,
            "max_steps": 100,
            "check_every": 50,
            "prune_rounds": 1,
            "prune_steps": 20,
        },
        "n_predictive": 100,
        "max_draws": 1000,
    },
    "default": {
        "n_starts": 6,
        "ls_max_nfev": 400,
        "sampler": {"n_walkers": 26, "max_steps": 2000, "check_every": 100},
    },
    "full": {"n_starts": 16, "ls_max_nfev": 2000, "sampler": {"max_steps": 20000}},
}


def recovery_lines(name, outcome) -> list[str]:
    cols = outcome.table["columns"]
    if "generating" not in cols or "q05" not in cols:
        return []
    lines = []
    for i, p in enumerate(cols["parameter"]):
        g = cols["generating"][i]
        inside = cols["q05"][i] <= g <= cols["q95"][i]
        informed = verdicts.informed(cols["contraction"][i])
        lines.append(
            f"| {name} | {p} | {g:.4g} | {cols['q05'][i]:.4g} - {cols['q95'][i]:.4g} | "
            f"{'yes' if inside else 'NO'} | {cols['contraction'][i]:.2f} | "
            f"{'informed' if informed else 'prior-dominated'} |"
        )
    return lines


def generating_line(name, outcome) -> str | None:
    """The recovery report's line on :func:`~bayestissue.inference.summary.generating_fit` (``None``
    without generating values or stored draws; a joint run's replicas each have their own)."""
    cols, idata = outcome.table["columns"], outcome.idata
    per_exp = [c.removeprefix("generating_") for c in cols if c.startswith("generating_")]
    if per_exp:
        return f"- {name}: not computed; the replicas {', '.join(per_exp)} come from different generating values"
    if "generating" not in cols or idata is None or "log_likelihood" not in idata.groups():
        return None
    gen = dict(zip(cols["parameter"], cols["generating"], strict=True))
    problem = outcome.problem
    if not all(n in gen and np.isfinite(gen[n]) for n in problem.names):
        return None
    fit = generating_fit(problem, idata, [gen[n] for n in problem.names])
    projected = ""
    if problem.material.tied:
        projected = f" (the model ties {problem.material.tied_text}: each takes its leader's generating value)"
    return (
        f"- {name}: log-likelihood at the generating values {fit['log_lik']:.1f}{projected}; over the posterior "
        f"draws {fit['q05']:.1f} to {fit['q95']:.1f} (5-95 %, max {fit['max']:.1f}); the generating values beat "
        f"{100.0 * fit['share_below']:.0f} % of the draws"
    )


#: Sampler coordinates of the mirror runs: the creep-curve coordinates fit a creep curve (T1); the ramp test T2
#: and the joint run get the ramp coordinates (box sheared along the profile over the fibre viscosity and the
#: matrix split). Measured with benchmarks/bench_sampling.py --experiment T2 --model mirror --moves mixture
#: --walkers 36 --adapt-rounds 2 --adapt-steps 500: box R-hat 1.019-1.066 at 6000 steps (tau 340-600, acceptance
#: 0.02-0.05); ramp CONVERGED after 2100-3900 steps, R-hat 1.0004, tau 20-25, acceptance 0.18, 85 s.
#: Joint run (studies' default settings, 40 walkers, seed SEED): creep coordinates at a 9000 cap NOT CONVERGED
#: (ensembles 0, 2, 3 short of 50 tau, 333 s); ramp coordinates with 2 x 500 adaptation reached the verdict only
#: after about 12 000 steps (tau up to 240 in three ensembles, 76 in the fourth: the fitted mixtures differ);
#: ramp with 3 x 1000 adaptation (MIRROR_ADAPT) CONVERGED after 5400-6300 steps (R-hat 1.0011, bulk ESS 4559,
#: max tau 84; 320 s with the machine shared).
MIRROR_COORDINATES = {"T2": "ramp", "joint": "ramp"}


def mirror_coordinates(exp_name: str) -> str:
    """Sampler coordinates of the mirror run ``exp_name`` (``T1``, ``T2``, ``joint``): MIRROR_COORDINATES,
    creep-curve coordinates otherwise."""
    return MIRROR_COORDINATES.get(exp_name, "creep")


def study_config(key: str, model: str, exp_name: str) -> dict:
    """Keyword arguments of :func:`~bayestissue.workflows.config.config_from_mapping` for the run ``exp_name``
    (``T1``, ``T2``, ``joint``) of ``model`` at budget ``key``."""
    mode, model_cfg = dict(BUDGETS[key]), dict(MODELS[model])
    if model == "full":
        mode["sampler"] = {**mode["sampler"], **FULL_SAMPLER[key]}
    if model == "mirror":
        mode["sampler"] = {**mode["sampler"], **MIRROR_SAMPLER[key]}
        if key == "default":
            mode["sampler"]["max_steps"] = MIRROR_CAPS.get(exp_name, 6000)
            mode["sampler"].update(MIRROR_ADAPT.get(exp_name, {}))
        model_cfg["coordinates"] = mirror_coordinates(exp_name)
    return {"seed": SEED, **model_cfg, **mode}


def generating_cost(outcome, name) -> float:
    refs = outcome.references.get(name, {})
    if "generating" not in refs:
        return float("nan")
    problem = outcome.problem
    mat = problem.material
    full = np.asarray(refs["generating"], dtype=float)
    theta = np.array([full[mat.names.index(n)] for n in mat.sampled_names])
    return 0.5 * float(np.sum(problem.residuals(theta[None, :]) ** 2))


def calibration_run(outcome, experiments, model: str, seconds: float) -> CalibrationRun:
    """The calibration record's entry for one run: verdicts, the posterior table and the draws' log-likelihood."""
    cols, meta = outcome.table["columns"], outcome.table["meta"]
    gen = cols.get("generating")
    rows = [
        ParameterRow(
            name=str(n), unit=str(cols["unit"][j]), generating=None if gen is None else float(gen[j]),
            q05=float(cols["q05"][j]), median=float(cols["median"][j]), q95=float(cols["q95"][j]),
            rhat=float(cols["rhat"][j]), contraction=float(cols["contraction"][j]), lower=float(cols["lower"][j]),
            upper=float(cols["upper"][j]),
        )
        for j, n in enumerate(cols["parameter"])
    ] if "q05" in cols else []  # fmt: skip
    ll = None
    if outcome.idata is not None and "log_likelihood" in outcome.idata.groups():
        ll = draw_log_likelihood(outcome.idata)
    check = outcome.fit_check or {}
    report = outcome.report
    return CalibrationRun(
        experiments=list(experiments),
        model=model,
        engine=outcome.config.engine if report is not None else "least squares",
        converged=None if report is None else bool(report.converged),
        convergence=meta.get("convergence", "not sampled"),
        misfit=any(c["misfit"] for c in check.values()) if check else None,
        fit_check=str(meta.get("fit_check", "")),
        parameters=rows,
        loglik_q05=None if ll is None else float(np.percentile(ll, 5)),
        loglik_q95=None if ll is None else float(np.percentile(ll, 95)),
        loglik_max=None if ll is None else float(ll.max()),
        seconds=float(seconds),
    )


#: The stated strain of the report's tissue terms: within both tests' range (T1 reaches 0.6, T2 1.1) and common to
#: them, so that their moduli compare.
TERMS_STRAIN = 0.3


def tissue_terms_record(folder, experiment, mode: str, *, runs=("T1_mirror", "T2_mirror", "joint_mirror"),
                        strain: float = TERMS_STRAIN, n_draws: int = 400) -> TissueTermsRecord:  # fmt: skip
    """The calibration stage's posteriors (``folder/calibration_<run>_posterior.nc``, those present) in a tissue's
    terms on ``experiment``'s tissue and specimen at ``strain``: ``n_draws`` draws thinned evenly, tied parameters
    taking their target's draw (the target variable's ``tied`` attribute)."""
    from pathlib import Path

    from bayestissue.inference.posterior import evenly, tied_sources
    from bayestissue.io.results import read_inference_data
    from bayestissue.workflows.tissue_terms import tissue_terms

    names = experiment.tissue.param_names
    out, units = {}, {}
    for run in runs:
        path = Path(folder) / f"calibration_{run}_posterior.nc"
        if not path.is_file():
            continue
        post = read_inference_data(path).posterior
        tied = tied_sources(post)
        draws = np.column_stack([post[tied.get(n, n)].values.ravel() for n in names])
        draws = draws[evenly(draws.shape[0], n_draws)]
        rows = tissue_terms(experiment, draws, strain=strain).rows()
        out[run] = {r["quantity"]: [r["median"], r["lower"], r["upper"]] for r in rows}
        units.update({r["quantity"]: r["unit"] for r in rows})
    return TissueTermsRecord(mode=mode, strain=float(strain), units=units, runs=out)

"""The calibration configuration's typed schema: every key of every section with its type, default and meaning.

:func:`check_mapping` refuses an unknown section or key, a value of the wrong type (``"50"`` for a number, ``true``
for a count: TOML booleans are not integers here) or out of range, naming the file, the section, the key, the value
and what was expected (the key kinds and checks: :mod:`bayestissue._schema`, shared with the experiment files).
:func:`config_markdown` renders the same table as ``docs/config.md`` (a test keeps the two equal), so the
documentation cannot drift from what the code accepts.
"""

from __future__ import annotations

from collections.abc import Mapping

from bayestissue._schema import Key, check_table, reference_rows
from bayestissue._validation import ValidationError, check_known_keys
from bayestissue.inference.likelihood import NOISE_MODELS
from bayestissue.inference.sampling.nested import SAMPLERS, SLICE_DIRECTIONS
from bayestissue.inference.sampling.options import MOVES, PROPOSALS
from bayestissue.workflows.coordinates import COORDINATES

#: The sampling engines (``[sampler] engine``).
ENGINES = ("emcee", "nested")
#: Independent checks of the emcee engine's verdict (``[sampler] cross_check``).
CROSS_CHECKS = ("none", "nested")

__all__ = ["CROSS_CHECKS", "ENGINES", "SCHEMA", "Key", "check_mapping", "config_markdown"]


SCHEMA: dict[str, dict[str, Key]] = {
    "parameters": {
        "prior": Key("choice", '"default"', "log-uniform moduli and rates, uniform gamma; or uniform on every box",
                     choices=("default", "uniform")),
        "fixed": Key("fixed", "none", "parameters held fixed: a table name -> value, or a list of names held at "
                     "their initial value"),
        "sampled": Key("names", "all", "sample only these parameters (the others held at their initial values)"),
        "bounds": Key("bounds", "Table 1", "per-parameter box, name -> [lower, upper]"),
        "priors": Key("name_text", "see prior", 'per-parameter prior, name -> "uniform" or "loguniform"'),
        "initial": Key("name_number", "Table 1 initial guess", "per-parameter initial value, name -> value"),
        "exchangeable": Key("groups", "none", "two parameter groups whose exchange leaves the likelihood unchanged "
                            "(the prior keeps the first group's leading parameter the larger)"),
        "tied": Key("name_text", "none", "name -> name whose value it takes (e.g. the mirror model: ginf3 = "
                    '"ginf2", gamma3 = "gamma2", beta3 = "beta2")'),
    },
    "likelihood": {
        "noise": Key("choice", '"gaussian"', "residual model", choices=tuple(sorted(NOISE_MODELS))),
        "sd": Key("sd", "sampled", 'known noise sd in the observed channel\'s unit (mm of displacement, mN of force, '
                  'kPa of stress), or "data" (each data file\'s noise_sd_mm header); omit '
                  "to sample it", low=0.0, low_open=True),
        "nu": Key("float", "4.0", "Student-t degrees of freedom (student_t)", low=0.0, low_open=True),
        "rho": Key("float", "sampled", "known lag-one correlation (ar1), in (-1, 1)"),
        "sd_bounds": Key("pair", "[1e-5 ptp, ptp] of the data", "box of a sampled sd (mm)"),
        "rho_bounds": Key("pair", "[-0.99, 0.99]", "box of a sampled rho (ar1)"),
    },
    "warmstart": {
        "n_starts": Key(
            "int", "8",
            "Latin-hypercube least-squares starts besides the paper's initial guess (a start the fit cannot leave is "
            "drawn again)",
            low=0,
        ),
        "max_nfev": Key("int", "1000", "evaluation cap of each least-squares fit", low=1),
        "jacobian": Key("choice", '"differences"', "Jacobian of the least squares: batched forward differences, or "
                        "exact (the forward model's sensitivities; not with a specimen parameter)",
                        choices=("differences", "exact")),
    },
    "sampler": {
        "seed": Key("int", "20261121", "master seed (starts, walkers, sampler streams, predictive noise)", low=0),
        "sample": Key("bool", "true", "run the sampling stage (false: least squares only)"),
        "engine": Key("choice", '"emcee"', "emcee ensembles from the least-squares optima, or nested sampling from "
                      "the prior (nautilus; multimodal and curved posteriors, and the evidence; options in [nested])",
                      choices=ENGINES),
        "cross_check": Key("choice", '"none"', "after emcee, a nested run of the same posterior ([nested] settings) "
                           "compared quantile by quantile; a disagreement makes the verdict NOT CONVERGED",
                           choices=CROSS_CHECKS),
        "coordinates": Key("choice", '"box"', "the sampler's coordinates: box, creep (creep tests, families 2/3 "
                           "tied) or ramp (force ramps)", choices=tuple(COORDINATES)),
        "moves": Key("choice", '"de_snooker"', "emcee moves; mixture = fitted Student-t independence proposals + DE",
                     choices=tuple(sorted(MOVES))),
        "proposal": Key("choice", '"own"', "mixture fitted per ensemble, or one shared by all ensembles",
                        choices=tuple(PROPOSALS)),
        "n_walkers": Key("int", "4 ndim", "walkers per ensemble (at least 2 ndim + 2; checked once ndim is known)",
                         low=4),
        "n_ensembles": Key("int", "4", "independent ensembles (R-hat between them needs at least 2)", low=2),
        "n_processes": Key("int", "min(n_ensembles, cores)", "parallel processes", low=1),
        "max_steps": Key("int", "20000", "step cap per ensemble (pruning and adaptation steps not counted)", low=1),
        "min_steps": Key("int", "0", "minimum steps per ensemble", low=0),
        "check_every": Key("int", "100", "steps between convergence checks", low=1),
        "tau_factor": Key("float", "50.0", "required length in autocorrelation times", low=0.0, low_open=True),
        "tau_rtol": Key("float", "0.01", "required relative change of tau between checks", low=0.0, low_open=True),
        "scatter": Key("float", "1.0", "multiplier of the Laplace sd for the initial walkers", low=0.0,
                       low_open=True),
        "prune_rounds": Key("int", "3", "discarded pre-run chunks that move stuck walkers (0: none)", low=0),
        "prune_steps": Key("int", "200", "steps per pruning chunk", low=0),
        "adapt_rounds": Key("int", "3", "adaptation rounds of the mixture proposal (discarded)", low=1),
        "adapt_steps": Key("int", "1000", "steps per adaptation round", low=1),
        "mixture_components": Key("int", "16", "largest number of mixture components", low=1),
        "scheduler": Key("scheduler", "none", 'where the ensembles go: none (processes of this machine), "local" '
                         '(dask tasks on a LocalCluster of n_processes workers) or a dask scheduler address '
                         '("tcp://host:8786"; docs/cluster.md)'),
    },
    "nested": {
        "n_live": Key("int", "1000", "live points of each nested run", low=10, high=100_000),
        "n_eff": Key("int", "1000", "importance effective sample size of each run", low=1),
        "n_runs": Key("int", "4", "independent nested runs (the verdict needs at least 4)", low=1, high=1000),
        "n_processes": Key("int", "min(n_runs, cores)", "parallel processes", low=1),
        "n_networks": Key("int", "4", "neural networks per bound", low=1, high=64),
        "network_tol": Key("float", "0.0", "nautilus: a network's training stops when its loss improves by less than "
                           "this for 10 epochs (0: until it stops improving; 1e-4 made 1.5x the calls per second of 0 "
                           "on the tendon preset, same evidence)", low=0.0, high=0.1),
        "f_live": Key("float", "0.01", "the exploration ends when the live set holds less than this share of the "
                      "evidence", low=0.0, low_open=True),
        "max_evaluations": Key("int", "none", "likelihood evaluations per run at most", low=1),
        "report_every": Key("int", "5000", "evaluations between progress reports (each run checkpoints after every "
                            "batch)", low=1),
        "marginalise_noise": Key("bool", "true", "integrate unknown Gaussian noise sds out analytically (exact; the "
                                 "runs sample the material parameters, the sds are drawn afterwards)"),
        "discard_exploration": Key("bool", "true", "leave the exploration phase's points out of the posterior and "
                                   "the evidence (unbiased)"),
        "sampler": Key("choice", '"nautilus"', "nautilus (importance nested sampling, neural-network bounds) or "
                       "ultranest (classic nested sampling, population slice sampler over batches, insertion-order "
                       "test in the verdict; f_live is its frac_remain, n_eff its min_ess)", choices=SAMPLERS),
        "slice_steps": Key("int", "2 x sampled dimensions", "UltraNest: slice steps of each new point (too few bias "
                           "the run; the insertion-order test may see it)", low=1),
        "directions": Key("choice", '"region"', "UltraNest: slice directions, the principal axes of the live "
                          "points' region or a mixture of those and differences of two live points (carries points "
                          "along a curved ridge)", choices=SLICE_DIRECTIONS),
        "population": Key("int", "100", "UltraNest: chains advanced together (points per likelihood batch)", low=1),
        "scheduler": Key("scheduler", "none", 'where the runs go: none (processes of this machine), "local" (dask '
                         'tasks on a LocalCluster of n_processes workers) or a dask scheduler address '
                         '("tcp://host:8786"; docs/cluster.md)'),
    },
    "output": {
        "max_draws": Key("int", "4000", "posterior draws stored in posterior.nc", low=1),
        "n_predictive": Key("int", "400", "draws of the posterior predictive", low=0),
    },
}  # fmt: skip


def check_mapping(cfg: Mapping, *, where: str = "configuration") -> None:
    """Check a parsed configuration against :data:`SCHEMA`.

    Raises
    ------
    ValidationError
        ``<where> [<section>] <key>: expected ..., got ...`` for the first bad entry; unknown sections and keys
        are named with the known ones.
    """
    for section, table in cfg.items():
        check_known_keys(f"{where} section", {section: None}, SCHEMA)
        if not isinstance(table, Mapping):
            raise ValidationError(f"{where} [{section}]", table, "a table of key = value entries")
        known = SCHEMA[section]
        check_table(table, known, f"{where} [{section}]")
    sampler = cfg.get("sampler", {})
    if "min_steps" in sampler and sampler["min_steps"] > sampler.get("max_steps", 20000):
        raise ValidationError(f"{where} [sampler] min_steps", sampler["min_steps"],
                              f"at most max_steps ({sampler.get('max_steps', 20000)})")  # fmt: skip


def config_markdown() -> str:
    """The configuration reference (``docs/config.md``), rendered from :data:`SCHEMA`."""
    lines = [
        "# Calibration configuration reference",
        "",
        "<!-- Generated from bayestissue/workflows/schema.py (config_markdown); tests/workflows/test_schema.py "
        "keeps it equal. -->",
        "",
        "`bayestissue fit EXPERIMENT... --config FILE`: a TOML file; every section and key is optional. Unknown "
        "sections and keys, values of the wrong type and values out of range are refused with the file, the key, "
        "the value and what was expected (exit status 2).",
    ]
    for section, keys in SCHEMA.items():
        lines += ["", f"## [{section}]", "", *reference_rows(keys)]
    return "\n".join(lines) + "\n"

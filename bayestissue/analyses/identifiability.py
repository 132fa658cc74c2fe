"""The identifiability study's workflow: budgets, experiments, calibration tasks, profiles, posterior measures.

Shared by ``studies/identifiability.py`` and ``studies/t1_vs_t2.py`` (the T1-vs-T2 analysis builds on the same
calibrations and profiles). The posteriors analysed are the calibration stage's mirror-model runs
(``calibration_{T1,T2,joint}_mirror_posterior.nc``, :data:`POSTERIOR_RUNS`), expanded to the 11 parameters; least
squares, profiles and sensitivities use the paper's 11 free parameters. Independent tasks fan out over
dask.distributed and are cached on disk by content hash; :func:`code_salt` (a hash of the package's source) is mixed
into every key, so any change to the package starts a fresh set of keys.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayestissue.analyses.verdicts import BOUND_EDGE, BOUND_SHARE
from bayestissue.identifiability import (
    ProfileOptions,
    analyse_sensitivities,
    bound_flags,
    contraction,
    correlation_matrix,
    kl_divergence,
    profile_all,
    scaled_sensitivities,
)
from bayestissue.inference.posterior import evenly
from bayestissue.mechanics import load_experiment, param_names, simulate
from bayestissue.paper import PAPER_BOUNDS, PAPER_PARAMETERS
from bayestissue.parallel import fan_out, start_client
from bayestissue.workflows.forward import ExperimentResiduals
from bayestissue.workflows.tasks import CalibrationTask, attach_posterior, drop_stuck_draws, run_task

__all__ = [
    "FIBRE1_NAMES",
    "LABELS",
    "MAX_RESTARTS",
    "MODES",
    "NAMES",
    "POSTERIOR_RUNS",
    "SALT",
    "Mode",
    "Timer",
    "at_bound",
    "base_tasks",
    "cached_map",
    "calibrations",
    "client_for",
    "close_client",
    "code_salt",
    "distinct",
    "experiments",
    "fibre1_tension_share",
    "interior",
    "local_analyses",
    "parse_args",
    "posterior_file",
    "posterior_measures",
    "profile_options",
    "profile_interval",
    "profiles",
    "residuals_for",
]

NAMES = param_names()
LABELS = ("T1", "T2", "joint")
#: Fibre family 1 (across the load): its parameters must stay uninformed by x tests (the sanity check).
FIBRE1_NAMES = ("ginf1", "gamma1", "beta1")
#: The posteriors analysed here are the calibration stage's mirror-model runs (family 3 tied to family 2;
#: studies/calibrate.py), reported for all 11 parameters (ginf3, gamma3, beta3 repeat family 2's draws).
POSTERIOR_RUNS = {"T1": "T1_mirror", "T2": "T2_mirror", "joint": "joint_mirror"}


def code_salt(package: Path | None = None) -> str:
    """Hash of every source file of the package: the cache key of a task then changes with the code."""
    from bayestissue.io.results import package_sha256

    return "code-" + package_sha256(package, parts=None)[:16]


#: mixed into every cache key (see code_salt)
SALT = code_salt()
#: a profile point this far below the reference optimum (in -2 log L) triggers a restart (ProfileOptions)
IMPROVEMENT_TOL = 1e-3
MAX_RESTARTS = 25  # high enough that the default study never reaches it (T1 needs 6; the report says where a run does)


@dataclass(frozen=True)
class Mode:
    """Budget of one run."""

    name: str
    n_starts: int  # Latin-hypercube least-squares starts (plus the paper's start and Table 1 estimates)
    profile_params: tuple  # parameters profiled
    profile_steps: int  # max steps per side
    profile_ftol: float
    rate_factors: tuple  # cause 1
    rate_profile_factors: tuple  # rates where beta2/beta3 are profiled
    rate_truths: int  # further draws of T1's posterior as truths, profiled at T2's rate
    n_replicates: int  # cause 2
    replicate_steps: int  # per replicate chain (one ensemble), after the mixture adaptation
    keep: int = 4000
    ls_nfev: int = 400  # evaluation cap per least-squares fit
    corners: bool = True  # corner plots (slow)
    replicate_adapt: tuple = (2, 500)  # mixture adaptation of a replicate chain: rounds, steps per round


MODES = {
    "quick": Mode(
        "quick",
        0,
        ("mu", "ginf1", "beta2"),
        6,
        1e-4,
        (0.1, 1.0, 10.0),
        (1.0,),
        2,
        2,
        60,
        keep=1000,
        ls_nfev=60,
        corners=False,
        replicate_adapt=(1, 60),
    ),
    "default": Mode(
        "default",
        2,
        NAMES,
        14,
        1e-6,
        (0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0),
        (0.01, 0.1, 1.0, 10.0),
        8,
        4,
        1500,
    ),
    "full": Mode(
        "full",
        8,
        NAMES,
        40,
        1e-8,
        tuple(np.round(np.logspace(-2, 2, 13), 4)),
        tuple(np.round(np.logspace(-2, 2, 7), 4)),
        20,
        40,
        6000,
        keep=20000,
        replicate_adapt=(3, 1000),
    ),
}


def parse_args(argv=None, description: str = "", *, root: Path):
    """The identifiability studies' command line (``root``: the repository, for the default folders)."""
    ap = argparse.ArgumentParser(description=description.splitlines()[0])
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="CI smoke run (about a minute)")
    g.add_argument("--full", action="store_true", help="publication-quality chains and profiles")
    ap.add_argument(
        "--scheduler",
        default=None,
        help="dask scheduler address, e.g. tcp://host:8786 (default: a LocalCluster on this machine)",
    )
    ap.add_argument("--n-workers", type=int, default=None, help="LocalCluster workers (default: cores)")
    ap.add_argument("--serial", action="store_true", help="no dask: run every task in this process")
    ap.add_argument(
        "--cache-dir",
        default=str(Path(root) / ".cache" / "identifiability"),
        help="result cache (content-hash keyed; delete it to recompute)",
    )
    ap.add_argument("--data", default=str(Path(root) / "data"))
    ap.add_argument("--out", default=str(Path(root) / "figures"))
    ap.add_argument(
        "--posteriors",
        default=None,
        help="folder of the calibration stage's results files calibration_<run>_posterior.nc (default: --out)",
    )
    ap.add_argument("--seed", type=int, default=20261121)
    a = ap.parse_args(argv)
    a.posteriors = a.posteriors or a.out
    a.mode = MODES["quick" if a.quick else "full" if a.full else "default"]
    return a


class Timer:
    """Prints the time of each stage."""

    def __init__(self, script):
        self.script, self.t0, self.rows = script, time.perf_counter(), []

    def stage(self, name):
        t = time.perf_counter()
        self.rows.append([name, t])
        print(f"[{self.script}] stage {name} ...", flush=True)

    def done(self):
        t_end = time.perf_counter()
        out = {}
        for k, (name, t) in enumerate(self.rows):
            nxt = self.rows[k + 1][1] if k + 1 < len(self.rows) else t_end
            out[name] = nxt - t
            print(f"[{self.script}] {name:<28s} {nxt - t:7.1f} s")
        print(f"[{self.script}] total {t_end - self.t0:.1f} s")
        return out


def client_for(args):
    return "serial" if args.serial else start_client(args.scheduler, n_workers=args.n_workers)


def close_client(client):
    if isinstance(client, str):
        return
    cluster = client.cluster if hasattr(client, "cluster") else None
    client.close()
    if cluster is not None:
        cluster.close()


def experiments(args):
    d = Path(args.data)
    return load_experiment(d / "T1.toml"), load_experiment(d / "T2.toml")


def base_tasks(args):
    """Least squares of the three calibrations (T1, T2, both with shared parameters), the paper's 11
    parameters."""
    e1, e2 = experiments(args)
    m = args.mode
    starts = (tuple(PAPER_PARAMETERS["T1"]), tuple(PAPER_PARAMETERS["T2"]))
    full = m.name != "quick"  # quick: each test starts only from its own Table 1 estimate
    kw = dict(n_steps=0, n_starts=m.n_starts, max_nfev=m.ls_nfev, paper_start=full)
    return [
        CalibrationTask((e1,), seed=args.seed + 1, label="T1", extra_starts=starts if full else starts[:1], **kw),
        CalibrationTask((e2,), seed=args.seed + 2, label="T2", extra_starts=starts if full else starts[1:], **kw),
        CalibrationTask((e1, e2), seed=args.seed + 3, label="joint", extra_starts=starts, **kw),
    ]


def posterior_file(args, lab) -> Path:
    """The calibration stage's results file of ``lab`` (mirror model: converged chains where the verdict
    says so)."""
    return Path(args.posteriors) / f"calibration_{POSTERIOR_RUNS[lab]}_posterior.nc"


def calibrations(args, client):
    """{label: CalibrationDraws} for T1, T2, joint: least squares (cached), posterior from the
    calibration stage's results files (studies/calibrate.py, which make study runs first)."""
    missing = [str(posterior_file(args, lab)) for lab in LABELS if not posterior_file(args, lab).is_file()]
    if missing:
        raise FileNotFoundError(
            f"identifiability: expected the calibration stage's posteriors, missing {missing}; "
            "run `python studies/calibrate.py` first (make study does)"
        )
    outs = fan_out(run_task, base_tasks(args), cache_dir=args.cache_dir, client=client, salt=SALT)
    return {
        lab: drop_stuck_draws(attach_posterior(o, posterior_file(args, lab), keep=args.mode.keep))
        for lab, o in zip(LABELS, outs, strict=True)
    }


def interior(theta, lo=PAPER_BOUNDS[:, 0], hi=PAPER_BOUNDS[:, 1]):
    """Clip into the open box (log steps around a point on a bound stay valid)."""
    return np.clip(theta, lo * (1 + 1e-9), hi * (1 - 1e-9))


def at_bound(theta, lo=PAPER_BOUNDS[:, 0], hi=PAPER_BOUNDS[:, 1], rel=1e-6):
    """-1 / +1 where a parameter sits on its lower / upper bound (within ``rel`` of the log-width), else 0."""
    u = (np.log(theta) - np.log(lo)) / (np.log(hi) - np.log(lo))
    return np.where(u <= rel, -1, np.where(u >= 1 - rel, 1, 0))


def fibre1_tension_share(outcome, exps, lab, n=200):
    """Share of ``n`` evenly spaced posterior draws in which fibre 1 carries tension in a test that ``lab``
    calibrates (T1, T2 or both)."""
    d = outcome.draws[evenly(outcome.draws.shape[0], n)]
    tests = {"T1": exps[:1], "T2": exps[1:], "joint": exps}[lab]
    loaded = np.zeros(d.shape[0], bool)
    for e in tests:
        loaded |= simulate(e, d, full=True).tension_kpa[..., 0].max(axis=-1) > 0
    return float(loaded.mean())


def residuals_for(args):
    e1, e2 = experiments(args)
    return {"T1": ExperimentResiduals((e1,)), "T2": ExperimentResiduals((e2,)), "joint": ExperimentResiduals((e1, e2))}


def local_analyses(res, theta):
    """Sensitivities, SVD and collinearity at ``theta[lab]`` (the best optimum found)."""
    out = {}
    for lab in LABELS:
        th = interior(theta[lab])
        S = scaled_sensitivities(res[lab].predict, th, noise_sd=res[lab].sd)
        out[lab] = analyse_sensitivities(S, th, NAMES, threshold=10.0)
    return out


def cached_map(args, client):
    """``map_fn`` for profile_all: one round of profiles fanned out over dask and cached."""

    def run(func, arg_list, kwargs):
        return fan_out(func, arg_list, cache_dir=args.cache_dir, client=client, kwargs=kwargs, salt=SALT)

    return run


def profile_options(m, **kw):
    return ProfileOptions(
        ftol=m.profile_ftol, step0=0.1, max_steps=m.profile_steps, improvement_tol=IMPROVEMENT_TOL, **kw
    )


def profiles(args, client, res, cal):
    """{label: ProfileSet}: profiles of the mode's parameters relative to the best optimum found (restarts)."""
    m = args.mode
    opt = profile_options(m, max_nfev=100 if m.name != "full" else 300)
    kw = dict(lower=PAPER_BOUNDS[:, 0], upper=PAPER_BOUNDS[:, 1], names=NAMES, batched=True, options=opt)
    idx = [NAMES.index(p) for p in m.profile_params]
    out = {}
    for lab in LABELS:
        out[lab] = profile_all(
            res[lab],
            interior(cal[lab].ls_x),
            idx,
            max_restarts=MAX_RESTARTS,
            refit_nfev=max(m.ls_nfev, 100),
            map_fn=cached_map(args, client),
            **kw,
        )
        ps = out[lab]
        print(
            f"  {lab}: profile reference chi2 {cal[lab].ls_chi2:.3f} (calibration) -> {ps.chi2_start:.3f} (polished)"
            f" -> {ps.chi2_min:.3f} after {ps.n_restarts} restart(s) from {list(ps.restart_from)}"
            f"{'' if ps.converged else ' (cap reached)'}"
        )
    return out


def profile_interval(ci) -> tuple[float | None, float | None]:
    """A profile's 95 % interval with each open side (NaN from the profile) as None."""
    return tuple(None if c is None or not np.isfinite(c) else float(c) for c in ci)


def distinct(outcome) -> list[int]:
    """Columns of the parameters that are sampled, not tied (a tied column repeats its target)."""
    return [j for j, n in enumerate(NAMES) if n not in outcome.tied]


def posterior_measures(cal):
    out = {}
    for lab in LABELS:
        u = cal[lab].u
        c = contraction(u, prior_var=np.full(u.shape[1], 1 / 12))
        kl = kl_divergence(u, prior_logpdf=lambda x: np.zeros_like(x), n_bins=30)
        fl = bound_flags(u, 0.0, 1.0, edge=BOUND_EDGE, min_share=BOUND_SHARE)
        out[lab] = {"contraction": c, "kl": kl, "flags": fl, "corr": correlation_matrix(u)}
    return out

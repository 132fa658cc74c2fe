"""Identifiability of the paper's 11 parameters from T1, T2 and both: local (sensitivities, SVD,
collinearity), profile likelihoods, and what the posteriors learnt (contraction, KL, bounds, correlation).

Writes figures/identifiability_*.png and figures/identifiability_summary.json (read by studies/report.py).
Independent runs fan out over dask.distributed (LocalCluster, or --scheduler tcp://host:8786) and are cached
on disk by content hash (--cache-dir): a re-run, or a run after a lost worker, computes only what is missing.

    python studies/identifiability.py [--quick | --full] [--scheduler ADDR] [--n-workers N]
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bayestissue.identifiability import (  # noqa: E402
    CHI2_1_95,
    ProfileOptions,
    analyse_sensitivities,
    bound_flags,
    contraction,
    correlation_matrix,
    kl_divergence,
    profile_likelihood,
    scaled_sensitivities,
)
from bayestissue.identifiability.calibration import (  # noqa: E402
    CalibrationTask,
    ExperimentResiduals,
    drop_stuck_draws,
    run_calibration,
)
from bayestissue.mechanics import (  # noqa: E402
    PAPER_BOUNDS,
    PAPER_PARAMETERS,
    load_experiment,
    param_names,
    simulate,
)
from bayestissue.parallel import fan_out, start_client  # noqa: E402
from bayestissue.plotting.identifiability import (  # noqa: E402
    plot_collinearity,
    plot_contraction,
    plot_corner_overlay,
    plot_marginals_overlay,
    plot_profiles,
    plot_singular_values,
)

ROOT = Path(__file__).resolve().parents[1]
NAMES = param_names()
LABELS = ("T1", "T2", "joint")
#: bump when the code of a cached task changes
SALT = "v1"


@dataclass(frozen=True)
class Mode:
    """Budget of one run."""

    name: str
    n_steps: int  # emcee steps per ensemble
    n_ensembles: int
    n_starts: int  # Latin-hypercube least-squares starts (plus the paper's start and Table 1 estimates)
    profile_params: tuple  # parameters profiled
    profile_steps: int  # max steps per side
    profile_ftol: float
    rate_factors: tuple  # cause 1
    rate_profile_factors: tuple  # rates where beta2/beta3 are profiled
    n_replicates: int  # cause 2
    replicate_steps: int
    keep: int = 4000
    ls_nfev: int = 400  # evaluation cap per least-squares fit
    corners: bool = True  # corner plots (slow)


MODES = {
    "quick": Mode(
        "quick",
        120,
        2,
        0,
        ("mu", "ginf1", "beta2"),
        6,
        1e-4,
        (0.1, 1.0, 10.0),
        (1.0,),
        2,
        60,
        keep=1000,
        ls_nfev=60,
        corners=False,
    ),
    "default": Mode(
        "default",
        700,
        2,
        2,
        NAMES,
        14,
        1e-6,
        (0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0),
        (0.01, 0.1, 1.0, 10.0),
        6,
        250,
    ),
    "full": Mode(
        "full",
        6000,
        4,
        8,
        NAMES,
        40,
        1e-8,
        tuple(np.round(np.logspace(-2, 2, 13), 4)),
        tuple(np.round(np.logspace(-2, 2, 7), 4)),
        40,
        2000,
        keep=20000,
    ),
}


def parse_args(argv=None, description=__doc__):
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
        default=str(ROOT / ".cache" / "identifiability"),
        help="result cache (content-hash keyed; delete it to recompute)",
    )
    ap.add_argument("--data", default=str(ROOT / "data"))
    ap.add_argument("--out", default=str(ROOT / "figures"))
    ap.add_argument("--seed", type=int, default=20261121)
    a = ap.parse_args(argv)
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
    """The three calibrations (T1, T2, both with shared parameters)."""
    e1, e2 = experiments(args)
    m = args.mode
    starts = (tuple(PAPER_PARAMETERS["T1"]), tuple(PAPER_PARAMETERS["T2"]))
    full = m.name != "quick"  # quick: each test starts only from its own Table 1 estimate
    kw = dict(
        n_steps=m.n_steps,
        n_ensembles=m.n_ensembles,
        n_starts=m.n_starts,
        keep=m.keep,
        max_nfev=m.ls_nfev,
        paper_start=full,
    )
    return [
        CalibrationTask((e1,), seed=args.seed + 1, label="T1", extra_starts=starts if full else starts[:1], **kw),
        CalibrationTask((e2,), seed=args.seed + 2, label="T2", extra_starts=starts if full else starts[1:], **kw),
        CalibrationTask((e1, e2), seed=args.seed + 3, label="joint", extra_starts=starts, **kw),
    ]


def calibrations(args, client):
    """{label: CalibrationOutcome} for T1, T2, joint (cached)."""
    outs = fan_out(run_calibration, base_tasks(args), cache_dir=args.cache_dir, client=client, salt=SALT)
    return {lab: drop_stuck_draws(o) for lab, o in zip(LABELS, outs, strict=True)}


def interior(theta, lo=PAPER_BOUNDS[:, 0], hi=PAPER_BOUNDS[:, 1]):
    """Clip into the open box (log steps around a point on a bound stay valid)."""
    return np.clip(theta, lo * (1 + 1e-9), hi * (1 - 1e-9))


def residuals_for(args):
    e1, e2 = experiments(args)
    return {"T1": ExperimentResiduals((e1,)), "T2": ExperimentResiduals((e2,)), "joint": ExperimentResiduals((e1, e2))}


def local_analyses(res, cal):
    out = {}
    for lab in LABELS:
        th = interior(cal[lab].ls_x)
        S = scaled_sensitivities(res[lab].predict, th, noise_sd=res[lab].sd)
        out[lab] = analyse_sensitivities(S, th, NAMES, threshold=10.0)
    return out


def profiles(args, client, res, cal):
    m = args.mode
    opt = ProfileOptions(
        ftol=m.profile_ftol, max_nfev=100 if m.name != "full" else 300, step0=0.1, max_steps=m.profile_steps
    )
    jobs = [(res[lab], interior(cal[lab].ls_x), NAMES.index(p)) for lab in LABELS for p in m.profile_params]
    kw = dict(lower=PAPER_BOUNDS[:, 0], upper=PAPER_BOUNDS[:, 1], names=NAMES, batched=True, options=opt)
    out = fan_out(profile_likelihood, jobs, cache_dir=args.cache_dir, client=client, kwargs=kw, salt=SALT)
    per = {lab: [] for lab in LABELS}
    for (r, _, _), pr in zip(jobs, out, strict=True):
        lab = next(lab for lab in LABELS if res[lab] is r)
        per[lab].append(pr)
    return per


def posterior_measures(cal):
    out = {}
    for lab in LABELS:
        u = cal[lab].u
        c = contraction(u, prior_var=np.full(u.shape[1], 1 / 12))
        kl = kl_divergence(u, prior_logpdf=lambda x: np.zeros_like(x), n_bins=30)
        fl = bound_flags(u, 0.0, 1.0)
        out[lab] = {"contraction": c, "kl": kl, "flags": fl, "corr": correlation_matrix(u)}
    return out


def _f(x):
    """JSON-friendly floats."""
    if isinstance(x, dict):
        return {str(k): _f(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_f(v) for v in x]
    if isinstance(x, np.ndarray):
        return _f(x.tolist())
    if isinstance(x, np.generic):
        return _f(x.item())
    if isinstance(x, float) and not np.isfinite(x):
        return None if np.isnan(x) else ("inf" if x > 0 else "-inf")
    return x


def savefig(fig, path):
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"  wrote {path}")


def main(argv=None) -> int:
    args = parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    T = Timer("identifiability")
    print(f"[identifiability] mode {args.mode.name}, cache {args.cache_dir}")
    client = client_for(args)
    try:
        T.stage("calibration (LS + MCMC)")
        cal = calibrations(args, client)
        for lab in LABELS:
            c = cal[lab]
            print(
                f"  {lab}: chi2_min {c.ls_chi2:.1f} (n = {c.loglik.shape[0] if c.loglik is not None else 0}"
                f" draws, acceptance {c.acceptance:.3f}, max R-hat "
                f"{np.nanmax(c.rhat) if c.rhat is not None else float('nan'):.3f})"
            )
        T.stage("local sensitivities")
        res = residuals_for(args)
        loc = local_analyses(res, cal)
        T.stage("profile likelihoods")
        prof = profiles(args, client, res, cal)
    finally:
        close_client(client)
    T.stage("posterior measures + figures")
    post = posterior_measures(cal)

    savefig(
        plot_profiles(prof, [p for p in NAMES if p in args.mode.profile_params], threshold=CHI2_1_95),
        out / "identifiability_profiles.png",
    )
    savefig(
        plot_singular_values({lab: loc[lab].singular_values for lab in LABELS}),
        out / "identifiability_singular_values.png",
    )
    savefig(
        plot_collinearity({lab: [(s, g) for s, g in loc[lab].collinearity] for lab in LABELS}),
        out / "identifiability_collinearity.png",
    )
    savefig(
        plot_contraction(
            {lab: post[lab]["contraction"] for lab in LABELS}, NAMES, ylabel="contraction 1 - var_post/var_prior"
        ),
        out / "identifiability_contraction.png",
    )
    savefig(
        plot_contraction({lab: post[lab]["kl"] for lab in LABELS}, NAMES, ylabel="KL(posterior || prior) (nats)"),
        out / "identifiability_kl.png",
    )
    savefig(plot_marginals_overlay({lab: cal[lab].u for lab in LABELS}, NAMES), out / "posterior_marginals.png")
    for lab in LABELS if args.mode.corners else ():
        fig = plot_corner_overlay({lab: cal[lab].u}, NAMES)
        savefig(fig, out / f"posterior_corner_{lab}.png")
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    for ax, lab in zip(axes, LABELS, strict=True):
        im = ax.imshow(post[lab]["corr"], vmin=-1, vmax=1, cmap="RdBu_r")
        ax.set_xticks(range(11), NAMES, rotation=90, fontsize=7)
        ax.set_yticks(range(11), NAMES, fontsize=7)
        ax.set_title(f"{lab}: posterior correlation (scaled box)", fontsize=9)
    fig.colorbar(im, ax=axes, shrink=0.8)
    savefig(fig, out / "posterior_correlation.png")

    summary = {"mode": args.mode.name, "names": NAMES, "calibration": {}, "local": {}, "profiles": {}, "posterior": {}}
    for lab in LABELS:
        c = cal[lab]
        summary["calibration"][lab] = {
            "ls_x": c.ls_x,
            "ls_chi2": c.ls_chi2,
            "chi2_parts": c.chi2_parts,
            "ls_active": c.ls_active,
            "ls_start_chi2": [s[1] for s in c.ls_starts],
            "n_obs": int(res[lab].sd.size),
            "median": np.median(c.draws, axis=0),
            "q05": np.quantile(c.draws, 0.05, axis=0),
            "q95": np.quantile(c.draws, 0.95, axis=0),
            "rhat": c.rhat,
            "acceptance": c.acceptance,
            "n_draws": c.draws.shape[0],
            "n_failed": c.n_failed,
            "n_dropped": c.n_dropped,
            "time_mcmc_s": c.time_mcmc_s,
            "u_mean": c.u.mean(axis=0),
            "u_sd": c.u.std(axis=0),
            "skew": ((c.u - c.u.mean(0)) ** 3).mean(0) / np.maximum(c.u.std(0), 1e-12) ** 3,
            "kurt": ((c.u - c.u.mean(0)) ** 4).mean(0) / np.maximum(c.u.std(0), 1e-12) ** 4,
        }
        a = loc[lab]
        gam = sorted(a.collinearity, key=lambda t: (len(t[0]), t[1]))
        summary["local"][lab] = {
            "theta": a.theta,
            "singular_values": a.singular_values,
            "se_log": a.std_error_log,
            "delta_msqr": a.delta_msqr,
            "sloppiest": a.sloppiest(3),
            "stiffest": [
                {n: float(w) for n, w in zip(NAMES, row, strict=True) if abs(w) > 0.1} for row in a.directions[:3]
            ],
            "largest_subsets": [[list(s), g] for s, g in a.largest_subsets[:5]],
            "pairs": [[list(s), g] for s, g in gam if len(s) == 2],
            "n_subsets_ok": int(sum(g < 10 for _, g in a.collinearity)),
            "n_subsets": len(a.collinearity),
            "n_informed": int(np.sum(a.singular_values > 1.0)),
        }
        summary["profiles"][lab] = [
            {
                "name": p.name,
                "classification": p.classification,
                "ci": p.ci,
                "theta_hat": p.theta_hat,
                "open": p.open_sides,
                "improved": p.improved,
                "n_points": int(p.values.size),
                "max_delta": float(np.nanmax(p.delta_chi2)),
                "min_delta": float(np.nanmin(p.delta_chi2)),
            }
            for p in prof[lab]
        ]
        pm = post[lab]
        summary["posterior"][lab] = {
            "contraction": pm["contraction"],
            "kl": pm["kl"],
            "at_lower": pm["flags"]["at_lower"],
            "at_upper": pm["flags"]["at_upper"],
            "share_lower": pm["flags"]["share_lower"],
            "share_upper": pm["flags"]["share_upper"],
            "max_abs_corr": [
                [NAMES[i], NAMES[j], float(pm["corr"][i, j])]
                for i, j in sorted(
                    ((i, j) for i in range(11) for j in range(i + 1, 11)), key=lambda ij: -abs(pm["corr"][ij])
                )[:5]
            ],
        }
    fam1 = [NAMES.index(n) for n in ("ginf1", "gamma1", "beta1")]
    summary["fibre1_check"] = {
        lab: {
            "contraction": post[lab]["contraction"][fam1],
            "kl": post[lab]["kl"][fam1],
            "sensitivity": loc[lab].delta_msqr[fam1],
            "uninformed": bool(
                np.all(np.abs(post[lab]["contraction"][fam1]) < 0.3) and np.all(post[lab]["kl"][fam1] < 0.1)
            ),
        }
        for lab in LABELS
    }
    e1, e2 = experiments(args)
    summary["fibre1_tension"] = {}
    for lab in LABELS:
        row = {}
        for e in (e1, e2):
            r = simulate(e, cal[lab].ls_x, full=True)
            row[e.name] = {
                "max_E22": float(r.strain[0, :, 1].max()),
                "max_tau1_kpa": float(r.tension_kpa[0, :, 0].max()),
            }
        summary["fibre1_tension"][lab] = row
    x = np.asarray(cal["T1"].ls_x, float)
    swapped = x.copy()
    swapped[5:8], swapped[8:11] = x[8:11], x[5:8]
    summary["swap_symmetry_max_abs_mm"] = max(
        float(np.max(np.abs(simulate(e, x) - simulate(e, swapped)))) for e in (e1, e2)
    )
    summary["timings_s"] = T.done()
    (out / "identifiability_summary.json").write_text(json.dumps(_f(summary), indent=1))
    print(f"  wrote {out / 'identifiability_summary.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

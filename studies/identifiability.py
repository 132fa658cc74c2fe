"""Identifiability of the paper's 11 parameters from T1, T2 and both: local (sensitivities, SVD,
collinearity), profile likelihoods, and what the posteriors learnt (contraction, KL, bounds, correlation).

The posteriors are the calibration stage's mirror-model runs (figures/calibration_{T1,T2,joint}_mirror_posterior.nc
from studies/calibrate.py, which make study runs first; --posteriors DIR to read them elsewhere), expanded to the 11
parameters; least squares, profiles and sensitivities use the paper's 11 free parameters.

Writes figures/identifiability_*.png and figures/identifiability_record.json (read by studies/report.py).
Independent runs fan out over dask.distributed (LocalCluster, or --scheduler tcp://host:8786) and are cached
on disk by content hash (--cache-dir): a re-run, or a run after a lost worker, computes only what is missing.
The cache key (bayestissue.parallel.task_key) hashes a task's function name and arguments, not its code, so the
salt here is a hash of the package's source: any change to bayestissue/ starts a fresh set of keys.

Profiles are relative to the best optimum found: when a profile point improves on the least-squares optimum by
more than 1e-3 in -2 log L, all parameters are re-optimised from it and every profile of that test is recomputed
(bayestissue.identifiability.profile_all); the restarts are recorded in the summary.

    python studies/identifiability.py [--quick | --full] [--scheduler ADDR] [--n-workers N]
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402

from bayestissue.analyses.identifiability import (  # noqa: E402
    LABELS,
    NAMES,
    Timer,
    calibrations,
    client_for,
    close_client,
    distinct,
    local_analyses,
    parse_args,
    posterior_measures,
    profiles,
    residuals_for,
)
from bayestissue.analyses.identifiability_record import identifiability_record  # noqa: E402
from bayestissue.analyses.records import FILES, IdentifiabilityRecord  # noqa: E402
from bayestissue.identifiability import (  # noqa: E402
    CHI2_1_95,
)
from bayestissue.io.figures import save_figure  # noqa: E402
from bayestissue.io.records import write_record  # noqa: E402
from bayestissue.mechanics import PAPER_TISSUE  # noqa: E402
from bayestissue.plotting.identifiability import (  # noqa: E402
    plot_collinearity,
    plot_contraction,
    plot_corner_overlay,
    plot_correlations,
    plot_marginals_overlay,
    plot_profiles,
    plot_singular_values,
)

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    args = parse_args(argv, __doc__, root=ROOT)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    T = Timer("identifiability")
    print(f"[identifiability] mode {args.mode.name}, cache {args.cache_dir}")
    client = client_for(args)
    try:
        T.stage("least squares + calibration posteriors")
        cal = calibrations(args, client)
        for lab in LABELS:
            c = cal[lab]
            print(
                f"  {lab}: chi2_min {c.ls_chi2:.1f} (n = {c.loglik.shape[0] if c.loglik is not None else 0}"
                f" draws, acceptance {c.acceptance:.3f}, max R-hat "
                f"{np.nanmax(c.rhat) if c.rhat is not None else float('nan'):.3f})"
            )
        res = residuals_for(args)
        T.stage("profile likelihoods")
        pset = profiles(args, client, res, cal)
        best_x = {lab: pset[lab].theta_hat for lab in LABELS}
        T.stage("local sensitivities")
        loc = local_analyses(res, best_x)
    finally:
        close_client(client)
    T.stage("posterior measures + figures")
    post = posterior_measures(cal)
    prof = {lab: list(pset[lab].profiles) for lab in LABELS}
    figures = []
    figures.append(
        save_figure(
            plot_profiles(
                prof,
                [p for p in NAMES if p in args.mode.profile_params],
                threshold=CHI2_1_95,
                units={p.name: p.unit for p in PAPER_TISSUE.parameters},
            ),
            out / "identifiability_profiles.png",
        )
    )
    figures.append(
        save_figure(
            plot_singular_values({lab: loc[lab].singular_values for lab in LABELS}),
            out / "identifiability_singular_values.png",
        )
    )
    figures.append(
        save_figure(
            plot_collinearity({lab: [(s, g) for s, g in loc[lab].collinearity] for lab in LABELS}),
            out / "identifiability_collinearity.png",
        )
    )
    # a run that fits by inflating its noise keeps its label in every figure of what it "learnt"
    tag = {lab: lab + (" (MISFIT)" if cal[lab].misfit else "") for lab in LABELS}
    figures.append(
        save_figure(
            plot_contraction(
                {tag[lab]: post[lab]["contraction"] for lab in LABELS},
                NAMES,
                ylabel="contraction 1 - var_post/var_prior",
            ),
            out / "identifiability_contraction.png",
        )
    )
    figures.append(
        save_figure(
            plot_contraction(
                {tag[lab]: post[lab]["kl"] for lab in LABELS}, NAMES, ylabel="KL(posterior || prior) (nats)"
            ),
            out / "identifiability_kl.png",
        )
    )
    figures.append(
        save_figure(plot_marginals_overlay({lab: cal[lab].u for lab in LABELS}, NAMES), out / "posterior_marginals.png")
    )
    for lab in LABELS if args.mode.corners else ():
        js = distinct(cal[lab])
        fig = plot_corner_overlay({lab: cal[lab].u[:, js]}, [NAMES[j] for j in js])
        figures.append(save_figure(fig, out / f"posterior_corner_{lab}.png"))
    cols = {lab: distinct(cal[lab]) for lab in LABELS}
    fig = plot_correlations({lab: post[lab]["corr"] for lab in LABELS}, NAMES, columns=cols)
    figures.append(save_figure(fig, out / "posterior_correlation.png"))

    path = out / FILES[IdentifiabilityRecord]
    write_record(path, identifiability_record(args, cal, res, pset, loc, post, [f.name for f in figures], T.done()))
    print(f"  wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

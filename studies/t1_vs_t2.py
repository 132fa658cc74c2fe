"""T1 versus T2: is the difference real, and which of the paper's three causes explains it?

Overlap of the separate posteriors, cross-prediction, tension of a joint fit, leave-one-experiment-out,
principal angles; then simulated tests of the causes: (1) loading rate, (2) fibre directions and volume
fractions (stereology replicates carried into a cut posterior; a free T2 fibre angle), (3) specimen
differences (a per-specimen stiffness scale). Writes figures/t1_vs_t2_*.png and figures/t1_vs_t2_record.json.

    python studies/t1_vs_t2.py [--quick | --full] [--scheduler ADDR] [--n-workers N]
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import bayestissue.analyses.discrepancy as dsc  # noqa: E402
import bayestissue.analyses.identifiability as ids  # noqa: E402
from bayestissue.analyses.records import FILES, CrossPrediction, DiscrepancyRecord, Tension  # noqa: E402
from bayestissue.identifiability import (  # noqa: E402
    bhattacharyya,
    informed_directions,
    principal_angles,
    psis_leave_out,
    scaled_sensitivities,
    tension,
)
from bayestissue.io.figures import save_figure  # noqa: E402
from bayestissue.io.records import write_record  # noqa: E402
from bayestissue.paper import PAPER_BOUNDS  # noqa: E402
from bayestissue.parallel import fan_out  # noqa: E402
from bayestissue.plotting.identifiability import (  # noqa: E402
    plot_corner_overlay,
    plot_cross_prediction,
    plot_marginals_overlay,
    plot_rate_study,
    plot_widths,
)
from bayestissue.workflows import run_task  # noqa: E402

NAMES = ids.NAMES


def main(argv=None) -> int:
    args = ids.parse_args(argv, __doc__, root=Path(__file__).resolve().parents[1])
    m = args.mode
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    T = ids.Timer("t1_vs_t2")
    rng = np.random.default_rng(args.seed)
    e1, e2 = ids.experiments(args)
    sd = 0.02
    S = {}
    client = ids.client_for(args)
    try:
        T.stage("calibrations (cached)")
        cal = ids.calibrations(args, client)
        T.stage("overlap, cross-prediction, tension")
        bc = bhattacharyya(cal["T1"].u, cal["T2"].u, n_bins=30)
        n_pp = 150 if m.name == "quick" else 600
        cp = {
            "T2|T1": dsc.cross_predict(e2, cal["T1"].draws, n=n_pp, sd=sd, rng=rng),
            "T1|T2": dsc.cross_predict(e1, cal["T2"].draws, n=n_pp, sd=sd, rng=rng),
            "T1|T1": dsc.cross_predict(e1, cal["T1"].draws, n=n_pp, sd=sd, rng=rng),
            "T2|T2": dsc.cross_predict(e2, cal["T2"].draws, n=n_pp, sd=sd, rng=rng),
        }
        res = ids.residuals_for(args)
        # best optima: the calibration's least squares improved by the profile restarts (cached profiles)
        pset = ids.profiles(args, client, res, cal)
        opt_x = {lab: pset[lab].theta_hat for lab in ids.LABELS}
        chi2 = {lab: pset[lab].chi2_min for lab in ids.LABELS}
        for lab in ids.LABELS:
            th = ids.interior(opt_x[lab])
            S[lab] = scaled_sensitivities(res[lab].predict, th, noise_sd=res[lab].sd)
        n_inf = int(np.sum(np.linalg.svd(S["joint"], compute_uv=False) > 1.0))
        ten = tension(chi2["joint"], [chi2["T1"], chi2["T2"]], 11)
        ten_eff = tension(chi2["joint"], [chi2["T1"], chi2["T2"]], max(n_inf, 1))
        loo = {}
        for k, lab in enumerate(("T1", "T2")):
            ll = cal["joint"].loglik[:, k]
            loo[lab] = psis_leave_out(ll)
        angles = principal_angles(informed_directions(S["T1"]), informed_directions(S["T2"]))

        T.stage("cause 1: loading rate")
        best = int(np.argmax(cal["T1"].loglik[:, 0]))
        rates = dsc.rate_study(args, client, e2, cal["T1"].draws[best], cal["T1"].draws)

        T.stage("causes 2+3: replicates, angle, scale")
        reps, pick, rtasks = dsc.replicate_tasks(args, cal, e1, e2)
        spec_tasks = dsc.specimen_tasks(args, opt_x, e1, e2)
        outs = fan_out(run_task, spec_tasks + rtasks, cache_dir=args.cache_dir, client=client, salt=ids.SALT)
    finally:
        ids.close_client(client)
    T.stage("summaries + figures")
    specimen, cut, pooled = dsc.specimen_and_cut(args, outs, cal, chi2, e1, e2, reps, pick)
    figures = []
    figures.append(
        save_figure(
            plot_marginals_overlay({"T1": cal["T1"].u, "T2": cal["T2"].u}, NAMES), out / "t1_vs_t2_marginals.png"
        )
    )
    if m.corners:
        js = ids.distinct(cal["T1"])
        figures.append(
            save_figure(
                plot_corner_overlay({"T1": cal["T1"].u[:, js], "T2": cal["T2"].u[:, js]}, [NAMES[j] for j in js]),
                out / "t1_vs_t2_corner.png",
            )
        )
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5))
    for ax, key, exp in (
        (axes[0, 0], "T1|T1", e1),
        (axes[0, 1], "T2|T2", e2),
        (axes[1, 0], "T1|T2", e1),
        (axes[1, 1], "T2|T1", e2),
    ):
        c = cp[key]
        tgt, src = key.split("|")
        plot_cross_prediction(
            exp.time_s,
            exp.displacement_mm,
            c["band"],
            c["median"],
            ax=ax,
            coverage=c["coverage"],
            title=f"{tgt} data, predicted from the {src} posterior",
        )
    fig.tight_layout()
    figures.append(save_figure(fig, out / "t1_vs_t2_cross_prediction.png"))
    names8 = dsc.MIRROR_NAMES
    figures.append(
        save_figure(
            plot_rate_study(
                rates["factors"],
                rates["se_log"],
                rates["profiles"],
                {p: float(rates["truth"][names8.index(p)]) for p in dsc.VISC},
                {p: tuple(PAPER_BOUNDS[names8.index(p)]) for p in dsc.VISC},
                _best_at_t2(rates, names8) + rates["at_t2"],
            ),
            out / "t1_vs_t2_rates.png",
        )
    )
    if cut:
        figures.append(
            save_figure(
                plot_widths(
                    {
                        "T1 one replicate (mean)": cut.tests["T1"].within_width,
                        "T1 cut (pooled)": cut.tests["T1"].cut_width,
                        "T2 one replicate (mean)": cut.tests["T2"].within_width,
                        "T2 cut (pooled)": cut.tests["T2"].cut_width,
                    },
                    NAMES,
                ),
                out / "t1_vs_t2_stereology_widths.png",
            )
        )
        figures.append(
            save_figure(
                plot_marginals_overlay(
                    {"T1": pooled["T1"], "T2": pooled["T2"]},
                    NAMES,
                    title="Cut posteriors: pooled over stereology replicates (dotted: the prior)",
                ),
                out / "t1_vs_t2_cut_marginals.png",
            )
        )

    def _tension(t):
        return Tension(Q=t["Q"], df=t["df"], p_value=t["p_value"])

    record = DiscrepancyRecord(
        mode=m.name,
        names=list(NAMES),
        bhattacharyya=bc,
        cross_prediction={
            k: CrossPrediction(coverage=v["coverage"], elpd=v["elpd"], n=v["n"], n_failed=v["n_failed"])
            for k, v in cp.items()
        },
        tension=_tension(ten),
        tension_effective=_tension(ten_eff),
        chi2=chi2,
        chi2_joint_parts=[float(np.sum(res[lab](opt_x["joint"]) ** 2)) for lab in ("T1", "T2")],
        loo_khat={lab: v["khat"] for lab, v in loo.items()},
        principal_angles_deg=angles,
        n_informed={lab: int(np.sum(np.linalg.svd(S[lab], compute_uv=False) > 1)) for lab in S},
        rates=dsc.rate_record(rates),
        scale=specimen["scale"],
        angle=specimen["angle"],
        cut=cut,
        figures=[f.name for f in figures],
        timings_s=T.done(),
    )
    path = out / FILES[DiscrepancyRecord]
    write_record(path, record)
    print(f"  wrote {path}")
    return 0


def _best_at_t2(rates, names) -> list:
    """The best draw's profiles at T2's rate (if profiled there) in the form of the further truths'."""
    pr = rates["profiles"].get(1.0)
    if pr is None:
        return []
    return [{"truth": {p: float(rates["truth"][names.index(p)]) for p in dsc.VISC},
             "ci": {p: pr[f"ci_{p}"] for p in dsc.VISC}, "classification": {p: pr[p] for p in dsc.VISC}}]  # fmt: skip


if __name__ == "__main__":
    raise SystemExit(main())

"""Controls of the T1-vs-T2 analysis: pairs from one tissue with each cause planted, verdicts by fixed rules.

Every scenario of bayestissue/workflows/controls.py (negative control, the two-branch fibre law, the T2 fibre angle
within and beyond the stereological spread, a T2 stiffness scale, fibre law + stiffness) on several noise seeds
(--quick 1, default 5, --full 10), each pair analysed by least squares (T1, T2, joint, one model per cause) and
judged by the controlled rules (bayestissue/analyses/verdicts.py). Writes figures/controls_record.json and
figures/t1_vs_t2_controls.png.

    python studies/controls.py [--quick | --full] [--serial]
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import bayestissue.analyses.identifiability as ids  # noqa: E402
from bayestissue.analyses import controls as ctl  # noqa: E402
from bayestissue.analyses import verdicts  # noqa: E402
from bayestissue.analyses.records import FILES, ControlPair, ControlsRecord, PairFit, ScenarioInfo  # noqa: E402
from bayestissue.io.figures import save_figure  # noqa: E402
from bayestissue.io.records import write_record  # noqa: E402
from bayestissue.parallel import fan_out  # noqa: E402
from bayestissue.plotting.controls import plot_controls  # noqa: E402

SEEDS = {"quick": 1, "default": 5, "full": 10}


def _pair_fit(fit: dict) -> PairFit:
    return PairFit(chi2=fit["chi2"], extra=fit["extra"], specimen=fit["specimen"], n=fit["n"],
                   angle_deg=fit.get("angle_deg"), scale=fit.get("scale"))  # fmt: skip


def main(argv=None) -> int:
    args = ids.parse_args(argv, __doc__, root=Path(__file__).resolve().parents[1])
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    T = ids.Timer("controls")
    t1, t2 = ids.experiments(args)
    n_seeds = SEEDS[args.mode.name]
    cases = [(sc, args.seed + s, t1, t2) for sc in ctl.SCENARIOS for s in range(n_seeds)]
    T.stage("the same analysis on the data files")
    data = fan_out(ctl.analyse_data, [(t1, t2)], cache_dir=args.cache_dir, client="serial", salt=ids.SALT)[0]
    data_verdict = ctl.pair_verdict(data["fit"])
    print(f"[controls] data: Q = {data_verdict.Q:.1f}, {data_verdict.kind} {data_verdict.named}")
    T.stage(f"{len(cases)} pairs ({len(ctl.SCENARIOS)} scenarios x {n_seeds} seeds)")
    done = []

    def progress(i, r):
        done.append(i)
        v = ctl.pair_verdict(r["fit"])
        print(f"[controls] {len(done)}/{len(cases)} {r['scenario']} seed {r['seed']}: Q = {v.Q:.1f}, "
              f"{v.kind} {v.named}", flush=True)  # fmt: skip

    client = ids.client_for(args)
    try:
        results = fan_out(
            ctl.run_case, cases, cache_dir=args.cache_dir, client=client, salt=ids.SALT, on_result=progress
        )
    finally:
        ids.close_client(client)
    T.stage("verdicts, table, figure")
    judged = [(r["scenario"], r["planted"], ctl.pair_verdict(r["fit"])) for r in results]
    table = verdicts.confusion(judged)
    tensions = {}
    for name, _, v in judged:
        tensions.setdefault(name, []).append(v.Q)
    fig = plot_controls(tensions, table, q_threshold=verdicts.tension_threshold(ctl.N_SHARED),
                        label=lambda key: verdicts.verdict_text(key, sep="\n"))  # fmt: skip
    save_figure(fig, out / "t1_vs_t2_controls.png")
    record = ControlsRecord(
        mode=args.mode.name,
        n_seeds=n_seeds,
        n_shared=ctl.N_SHARED,
        noise_sd_mm=ctl.NOISE_SD_MM,
        base_parameters=ctl.BASE_PARAMETERS,
        scenarios=[ScenarioInfo(s.name, list(s.planted), s.strength) for s in ctl.SCENARIOS],
        pairs=[ControlPair(r["scenario"], r["planted"], r["seed"], _pair_fit(r["fit"])) for r in results],
        data=_pair_fit(data["fit"]),
        timings_s=T.done(),
    )
    write_record(out / FILES[ControlsRecord], record)
    print("wrote", out / FILES[ControlsRecord])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

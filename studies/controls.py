"""Controls of the T1-vs-T2 analysis: pairs from one tissue with each cause planted, verdicts by fixed rules.

Every scenario of bayestissue/workflows/controls.py (negative control, the two-branch fibre law, the T2 fibre angle
within and beyond the stereological spread, a T2 stiffness scale, fibre law + stiffness) on several noise seeds
(--quick 1, default 5, --full 10), each pair analysed by least squares (T1, T2, joint, one model per cause) and
judged by the rules fixed in that module. Writes figures/controls_summary.json and figures/t1_vs_t2_controls.png.

    python studies/controls.py [--quick | --full] [--serial]
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
from scipy.stats import chi2 as chi2_dist  # noqa: E402

import bayestissue.workflows.identifiability as ids  # noqa: E402
from bayestissue.io.figures import save_figure  # noqa: E402
from bayestissue.parallel import fan_out  # noqa: E402
from bayestissue.plotting.controls import plot_controls  # noqa: E402
from bayestissue.workflows import controls as ctl  # noqa: E402

SEEDS = {"quick": 1, "default": 5, "full": 10}


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
    data_verdict = ctl.verdict(data["fit"])
    print(f"[controls] data: Q = {data_verdict['tension']['Q']:.1f}, {data_verdict['kind']} {data_verdict['named']}")
    T.stage(f"{len(cases)} pairs ({len(ctl.SCENARIOS)} scenarios x {n_seeds} seeds)")
    done = []

    def progress(i, r):
        done.append(i)
        v = ctl.verdict(r["fit"])
        print(f"[controls] {len(done)}/{len(cases)} {r['scenario']} seed {r['seed']}: Q = {v['tension']['Q']:.1f}, "
              f"{v['kind']} {v['named']}", flush=True)  # fmt: skip

    client = ids.client_for(args)
    try:
        results = fan_out(
            ctl.run_case, cases, cache_dir=args.cache_dir, client=client, salt=ids.SALT, on_result=progress
        )
    finally:
        ids.close_client(client)
    T.stage("verdicts, table, figure")
    records = [dict(r, verdict=ctl.verdict(r["fit"])) for r in results]
    table = ctl.confusion(records)
    q_thr = float(chi2_dist.isf(ctl.P_TENSION, ctl.N_SHARED))
    fig = plot_controls(records, table, q_threshold=q_thr, label=lambda key: ctl.verdict_text(key, sep="\n"))
    save_figure(fig, out / "t1_vs_t2_controls.png")
    summary = {
        "mode": args.mode.name,
        "n_seeds": n_seeds,
        "rules": {"p_tension": ctl.P_TENSION, "dbic": ctl.DBIC, "dchi2_tie": ctl.DCHI2_TIE, "df": ctl.N_SHARED},
        "q_threshold": q_thr,
        "base_parameters": list(map(float, ctl.BASE_PARAMETERS)),
        "scenarios": [{"name": s.name, "planted": list(s.planted), "strength": s.strength} for s in ctl.SCENARIOS],
        "records": records,  # every key is a string already (cause models "1", "1+3" ...): JSON as they are
        "table": table,
        "data": {"fit": data["fit"], "verdict": data_verdict},
    }
    summary["timings_s"] = T.done()
    (out / "controls_summary.json").write_text(json.dumps(summary, indent=1))
    print("wrote", out / "controls_summary.json")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Do two calibrations of one posterior agree? The marginals of two summary tables (e.g. emcee and nested).

For every parameter in both tables, the 5 %, 50 % and 95 % posterior quantiles are mapped to the scaled box
coordinate u in [0, 1] (log scale for log-uniform boxes, as the sampler sees them) and compared: the marginals agree
when every quantile differs by less than ``--tol`` (default 0.1) of the first table's 90 % width in u. Monte Carlo
error of a quantile at ESS 1000 is about 0.02 of that width, so 0.1 leaves room for both runs' errors and still
flags a shifted or narrower marginal (a missed mode moves the median by a good part of the width).

    python benchmarks/compare_engines.py figures/calibration_summary_T1_mirror.csv runs/T1_nested/summary.csv
"""

from __future__ import annotations

import argparse

import numpy as np

from bayestissue.io.tables import read_table


def _unit(x, lo, hi, prior):
    if prior == "loguniform":
        return (np.log(x) - np.log(lo)) / (np.log(hi) - np.log(lo))
    return (x - lo) / (hi - lo)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("first", help="summary.csv of the reference calibration")
    ap.add_argument("second", help="summary.csv to compare with it")
    ap.add_argument("--tol", type=float, default=0.1, help="largest quantile difference / reference 90 %% width")
    args = ap.parse_args(argv)
    need = ("parameter", "prior", "lower", "upper", "q05", "median", "q95")
    a, meta_a = read_table(args.first, required=need)
    b, meta_b = read_table(args.second, required=need)
    rows_b = {p: i for i, p in enumerate(b["parameter"])}
    print(f"reference: {args.first}\n  {meta_a.get('convergence', '')[:160]}")
    print(f"compared:  {args.second}\n  {meta_b.get('convergence', '')[:160]}")
    print("| parameter | reference q05 / median / q95 | compared q05 / median / q95 | largest difference / width |")
    print("|---|---|---|---|")
    worst = 0.0
    for i, p in enumerate(a["parameter"]):
        if p not in rows_b:
            continue
        j = rows_b[p]
        lo, hi, prior = float(a["lower"][i]), float(a["upper"][i]), str(a["prior"][i])
        qa = np.array([float(a[k][i]) for k in ("q05", "median", "q95")])
        qb = np.array([float(b[k][j]) for k in ("q05", "median", "q95")])
        ua, ub = _unit(qa, lo, hi, prior), _unit(qb, lo, hi, prior)
        rel = float(np.max(np.abs(ua - ub)) / max(ua[2] - ua[0], 1e-12))
        worst = max(worst, rel)
        fmt = " / ".join
        print(
            f"| {p} | {fmt(f'{v:.4g}' for v in qa)} | {fmt(f'{v:.4g}' for v in qb)} | "
            f"{rel:.3f}{'' if rel < args.tol else ' DIFFERS'} |"
        )
    verdict = "AGREE" if worst < args.tol else "DIFFER"
    print(f"marginals {verdict}: largest quantile difference {worst:.3f} of the reference 90 % width (< {args.tol})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

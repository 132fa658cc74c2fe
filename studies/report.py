"""Write figures/REPORT.md from the summaries of studies/identifiability.py and studies/t1_vs_t2.py.

    python studies/report.py [--out figures]

Every number in the report is read from figures/identifiability_summary.json and figures/t1_vs_t2_summary.json;
the verdicts are rules on those numbers, stated next to them (bayestissue.workflows.report, one module per section).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from bayestissue.workflows.report import report_text

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "figures"))
    ap.add_argument("--quick", action="store_true", help="accepted for symmetry with the other studies")
    ap.add_argument("--full", action="store_true", help="accepted for symmetry with the other studies")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    out = Path(args.out)
    A = json.loads((out / "identifiability_summary.json").read_text())
    B = json.loads((out / "t1_vs_t2_summary.json").read_text())
    (out / "REPORT.md").write_text(report_text(A, B, out))
    print(f"[report] wrote {out / 'REPORT.md'} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Write figures/REPORT.md from the study's records (bayestissue.report: a Jinja2 template over typed records).

    python studies/report.py [--out figures]

Every number and verdict in the report comes from the records the other stages wrote (identifiability_record.json,
t1_vs_t2_record.json, and where their stages ran calibration_record.json, controls_record.json and
measured_record.json); the explanation that does not change lives in docs/report_guide.md.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from bayestissue.report import write_report

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "figures"))
    ap.add_argument("--quick", action="store_true", help="accepted for symmetry with the other studies")
    ap.add_argument("--full", action="store_true", help="accepted for symmetry with the other studies")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    path = write_report(args.out)
    print(f"[report] wrote {path} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

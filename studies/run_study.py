"""The main study (``make study``): every stage on the bundled data, writing into figures/ (--quick: figures/quick/).

Stages run in order, each a script in studies/ with a ``main(argv)``; the time of each is printed at the end. A stage
that raises or returns a nonzero exit code is reported as failed, the others still run, and the study exits 1.
``--quick`` is a smoke run (CI-sized chains, about 2 minutes) and writes into its own folder, never over the committed
results; ``--full`` publication-quality chains; the default takes about 30 minutes on an idle 2-core machine
(2026-11-25, before the laws stage: 1217 s of stages, 684 s of them calibration) and took 3002 s on 2026-11-27 on a
shared machine running other fits beside it (calibration 1073 s, controls 416 s, T1 vs T2 368 s, laws 779 s), and
2190 s the same day from a fresh clone with two low-priority fits beside it (calibration 851 s, laws 594 s with
Ogden 3, controls 247 s, T1 vs T2 197 s, micrographs 133 s, identifiability 119 s).

    python studies/run_study.py [--quick | --full] [--only STAGE ...]   # STAGE: a script or a stage name
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import time
import traceback
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")

HERE = Path(__file__).resolve().parent

#: (stage name, script) in execution order: data -> figures -> calibration -> identifiability -> report.
STAGES = (
    ("forward model", "forward_figure.py"),
    ("stereology", "stereology_figures.py"),
    ("micrographs", "micrograph_validation.py"),
    ("calibration", "calibrate.py"),
    ("identifiability", "identifiability.py"),
    ("T1 vs T2", "t1_vs_t2.py"),
    ("controls", "controls.py"),
    ("measured data", "measured_data.py"),
    ("laws", "law_choice.py"),
    ("specimens", "specimens.py"),
    ("full model", "full_model.py"),
    ("evidence check", "evidence_check.py"),
    ("branches", "tendon_branches.py"),
    ("report", "report.py"),
)


def _load(script: str):
    spec = importlib.util.spec_from_file_location(script[:-3], HERE / script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="smoke run (short chains)")
    mode.add_argument("--full", action="store_true", help="publication-quality chains")
    ap.add_argument(
        "--only",
        nargs="+",
        metavar="STAGE",
        help="run only these stages, by script or name (e.g. calibrate.py or calibration)",
    )
    ap.add_argument("--out", type=Path, default=None, help="output folder (default: figures/; --quick: figures/quick/)")
    args = ap.parse_args(argv)
    out = args.out or HERE.parent / "figures" / ("quick" if args.quick else "")
    known = {key: script for name, script in STAGES for key in (name, script)}
    unknown = [s for s in args.only or () if s not in known]
    if unknown:
        ap.error(f"--only: expected stages among {[script for _, script in STAGES]} or their names, got {unknown}")
    only = {known[s] for s in args.only or ()}
    flags = (["--quick"] if args.quick else ["--full"] if args.full else []) + ["--out", str(out)]
    timings, failed = [], []
    t_all = time.perf_counter()
    for name, script in STAGES:
        if only and script not in only:
            continue
        print(f"\n=== stage: {name} ({script} {' '.join(flags)}) ===", flush=True)
        t0 = time.perf_counter()
        try:
            rc = _load(script).main(flags)
        except Exception:  # a failed stage is reported; the others still run
            traceback.print_exc()
            rc = 1
        if rc:  # a stage's own exit code (e.g. 2: a record it cannot read) fails the study as an exception does
            print(f"[study] stage {name} ({script}) failed (exit code {rc})", file=sys.stderr, flush=True)
            failed.append(name)
        timings.append((name, time.perf_counter() - t0))
    print("\n=== time per stage ===")
    for name, sec in timings:
        print(f"{name:<28s} {sec:8.1f} s")
    print(f"{'total':<28s} {time.perf_counter() - t_all:8.1f} s")
    if failed:
        print(f"FAILED stages: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

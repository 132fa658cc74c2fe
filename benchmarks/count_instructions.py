"""Machine instructions of one T1 forward call, plug-in kernel against the frozen pre-plug-in kernel
(benchmarks/legacy_kernel.py), counted by valgrind's callgrind: the deterministic measure behind the speed target
(at most 1.10x), which wall time on a shared machine gives only to about +-0.1 per run (docs/verification.md,
"Speed of the plug-in kernel").

Per kernel, two runs under callgrind in fresh processes, one and two calls on the same box draws, counting only the
instructions of compiled code (entered through numba's dispatcher); their difference is one call's instructions.
Both kernels are compiled natively first, for one CPU model (``NUMBA_CPU_NAME``/``NUMBA_CPU_FEATURES``, haswell by
default, into a temporary numba cache): valgrind does not emulate this machine's AVX-512, so without a fixed model
numba would see another CPU under valgrind and compile everything again there (tens of minutes).

    OPENBLAS_NUM_THREADS=1 python benchmarks/count_instructions.py [--n-sets 500] [--cpu haswell]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Where numba's dispatcher enters compiled code: only the instructions under it are counted (not the interpreter,
#: whose garbage collections made the counts of two runs differ by millions).
COMPILED = "call_cfunc*"

#: The CPU features of ``--cpu haswell`` (what valgrind can run).
_FEATURES = "64bit avx avx2 bmi bmi2 cmov cx16 f16c fma lzcnt mmx movbe popcnt sse sse2 sse3 sse4.1 sse4.2 ssse3"
HASWELL = ",".join(f"+{f}" for f in _FEATURES.split())


def drive(kernel: str, n_sets: int, calls: int) -> None:
    """``calls`` calls of ``kernel`` ("plugin" or "frozen") on the same ``n_sets`` box draws (after a 2-set call
    that loads the compiled code)."""
    sys.path.insert(0, str(ROOT))
    import numpy as np

    from bayestissue.mechanics import load_experiment
    from benchmarks.bench_forward import draw_box, kernel_runs

    exp = load_experiment(ROOT / "data" / "T1.toml")
    sets = draw_box(n_sets, np.random.default_rng(1))
    pick = 0 if kernel == "plugin" else 1
    warm, run = kernel_runs(exp, sets[:2])[pick], kernel_runs(exp, sets)[pick]

    warm()
    for _ in range(calls):
        run()


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-sets", type=int, default=500)
    ap.add_argument("--cpu", default="haswell", help="CPU model numba compiles for (haswell: its features are known)")
    ap.add_argument("--features", default=None, help="its LLVM features (default: haswell's)")
    ap.add_argument("--drive", nargs=2, metavar=("KERNEL", "CALLS"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.drive:
        drive(args.drive[0], args.n_sets, int(args.drive[1]))
        return {}
    if shutil.which("valgrind") is None:
        raise SystemExit("count_instructions.py: valgrind not found (install it, e.g. apt install valgrind)")
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", NUMBA_CACHE_DIR=str(Path(tmp) / "numba"),
                   NUMBA_CPU_NAME=args.cpu, NUMBA_CPU_FEATURES=args.features or HASWELL)  # fmt: skip
        me = [sys.executable, str(Path(__file__).resolve()), "--n-sets", str(args.n_sets), "--drive"]
        for kernel in ("plugin", "frozen"):  # compile natively into the cache the runs under valgrind load
            subprocess.run([*me, kernel, "0"], env=env, check=True)

        def count(job):
            kernel, calls = job
            out = Path(tmp) / f"{kernel}.{calls}.out"
            subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no", f"--toggle-collect={COMPILED}",
                            f"--callgrind-out-file={out}", *me, kernel, str(calls)],
                           env=env, check=True, capture_output=True)  # fmt: skip
            return int(re.search(r"^summary: (\d+)", out.read_text(), re.M).group(1))

        jobs = [(k, c) for k in ("plugin", "frozen") for c in (1, 2)]
        with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
            totals = dict(zip(jobs, pool.map(count, jobs), strict=True))
    per = {k: totals[(k, 2)] - totals[(k, 1)] for k in ("plugin", "frozen")}
    ratio = per["plugin"] / per["frozen"]
    print(
        f"instructions per T1 call on {args.n_sets} box draws (callgrind, compiled for {args.cpu}): plug-in kernel "
        f"{per['plugin'] / 1e6:.1f} M, frozen kernel {per['frozen'] / 1e6:.1f} M, ratio {ratio:.4f} (target <= 1.10)"
    )
    return {"plugin": per["plugin"], "frozen": per["frozen"], "ratio": ratio}


if __name__ == "__main__":
    main()

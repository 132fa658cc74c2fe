"""figures/forward_T1_T2.png: each experiment's replica data with the curves simulated for the paper's initial guess
and its two Table 1 results (the analogue of the paper's Figs. 10 and 12).

    python studies/forward_figure.py [--data data] [--out figures]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bayestissue.mechanics import load_experiment, simulate  # noqa: E402
from bayestissue.paper import PAPER_PARAMETERS  # noqa: E402
from bayestissue.plotting.mechanics import plot_fit_curves  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
LABELS = {"initial": "paper's initial guess", "T1": "paper Table 1, T1 result", "T2": "paper Table 1, T2 result"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT / "data")
    ap.add_argument("--out", type=Path, default=ROOT / "figures")
    ap.add_argument("--quick", action="store_true", help="accepted for uniformity; this stage is always fast")
    ap.add_argument("--full", action="store_true", help="accepted for uniformity")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    lines = ["| experiment | parameter set | RMS vs data (mm) | final displacement (mm) |", "|---|---|---|---|"]
    for ax, name in zip(axes, ("T1", "T2"), strict=True):
        exp = load_experiment(args.data / f"{name}.toml")
        curves = {}
        for key, label in LABELS.items():
            u = simulate(exp, PAPER_PARAMETERS[key])
            curves[label] = u
            rms = float(np.sqrt(np.mean((u - exp.displacement_mm) ** 2)))
            lines.append(f"| {name} | {label} | {rms:.4f} | {u[-1]:.3f} |")
        plot_fit_curves(exp, curves, ax=ax, title=f"{name}: {exp.protocol.kind} test (synthetic replica data)")
    fig.suptitle("Forward model on the replica data: the paper's initial guess and Table 1 results")
    fig.tight_layout()
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "forward_T1_T2.png"
    fig.savefig(path, dpi=130)
    plt.close(fig)
    (args.out / "forward_T1_T2.md").write_text(
        "# Forward model vs replica data\n\nReplica data are synthetic (see data/README.md).\n\n"
        + "\n".join(lines)
        + "\n"
    )
    print("\n".join(lines))
    print(f"forward_figure: wrote {path} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Every benchmark the README shows runs (a smoke version: small sizes; the figures they print are not checked
here, only that they run and print them). The README's own commands with their full sizes are timed in the README."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SMOKE = {
    "bench_forward.py": (["--n-sets", "40", "--n-baseline", "1", "--rounds", "1", "--skip-compile"],
                         "plug-in kernel / frozen pre-plug-in kernel"),
    "bench_sensitivity.py": (["--n-sets", "4", "--repeats", "1"], "x a forward run"),
    "bench_overhead.py": (["--sets", "2", "--reps", "3", "--repeats", "1"], "x kernel"),
    "bench_sampling.py": (["--model", "mirror", "--coordinates", "creep", "--moves", "mixture", "--walkers", "36",
                           "--max-steps", "60", "--adapt-rounds", "1", "--adapt-steps", "100"], "R-hat"),
    "bench_micrographs.py": (["--sizes", "120x160", "--sections", "6", "--tile", "120x160"], "px x 6 sections"),
    "coverage_hierarchy.py": (["--reps", "1", "--sizes", "2", "--stage1-steps", "200"],
                              "90 % intervals covering the generating value"),
    "hierarchy_vs_joint.py": (["--stage1-steps", "200", "--steps", "200", "--walkers", "48", "--population-draws",
                               "300"], "largest quantile difference"),
    "rosenbrock_evidence.py": (["--n-live", "100", "--n-eff", "200", "--runs", "2", "--blocks", "1", "--depth", "2",
                                "--exact-draws", "20000"], "within 2 of their MC errors"),
    "rosenbrock_evidence.py --sampler ultranest": (["--n-live", "100", "--n-eff", "200", "--runs", "2", "--blocks",
                                                    "1", "--depth", "2", "--exact-draws", "20000", "--population",
                                                    "10"], "insertion test"),
    "sbc_nested.py --sampler ultranest": (["--reps", "1", "--live", "30", "--neff", "30", "--processes", "1"],
                                          "90 % intervals"),
    "sbc_emcee.py": (["--problems", "creep", "--reps", "1", "--max-steps", "200", "--ensembles", "2",
                      "--processes", "1"], "90 % intervals holding the truth"),
    "cluster_scaling.py": (["--n-live", "50", "--runs", "2", "--workers", "1", "--max-evaluations", "500"],
                           "projected"),
    "cluster_scaling.py --sampler ultranest": (["--n-live", "30", "--runs", "2", "--workers", "1",
                                                "--max-evaluations", "2000"], "projected"),
    "nested_samplers.py": (["--n-live", "50", "--runs", "2", "--max-evaluations", "1500"], "on the quantiles"),
    "gamma_box_peak.py": (["--upper", "0.95", "0.99", "--seeds", "1", "--maxiter", "3", "--popsize", "4"],
                          "against the paper's 0.95"),
    "compare_engines.py": ([str(ROOT / "figures" / "calibration_summary_T1_mirror.csv"),
                            str(ROOT / "figures" / "calibration_summary_T1_mirror.csv")], "marginals AGREE"),
}  # fmt: skip


def test_every_benchmark_in_the_readme_has_a_smoke_run():
    readme = (ROOT / "README.md").read_text()
    scripts = [p for p in (ROOT / "benchmarks").glob("*.py") if '__name__ == "__main__"' in p.read_text()]
    shown = {p.name for p in scripts if p.name in readme}
    assert shown <= {key.split()[0] for key in SMOKE}, shown - {key.split()[0] for key in SMOKE}


@pytest.mark.slow
@pytest.mark.parametrize("script", sorted(SMOKE))
def test_benchmark_smoke(script):
    args, expected = SMOKE[script]
    name, *options = script.split()  # a key may carry the options of a second command the README shows
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", MPLBACKEND="Agg")
    run = subprocess.run([sys.executable, str(ROOT / "benchmarks" / name), *options, *args], capture_output=True,
                         text=True, cwd=ROOT, env=env, timeout=900)  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    assert expected in run.stdout, run.stdout[-3000:]

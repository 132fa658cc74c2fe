"""Writes ``data/synthetic/tendon_groups/``: a SYNTHETIC two-group study of tendon stress relaxation for the
hierarchical model (``bayestissue hierarchy``): 4 "fresh" and 4 "incubated" specimens, each one ramp-and-hold test
made by this package's forward model from parameters drawn from a known population, plus Gaussian noise. No
measured data.

Model: the ``tendon`` preset with the exponential (HGO) fibre, a recruitment stretch and one Prony branch; held at
known values: mu = kappa = 10 kPa, k2_1 = 2, disp1 = 0.02, lamr1 = 1.01 (``fit.toml`` fixes them). Per specimen,
on the log scale: ln k1_1 ~ N(ln 5e4 + d, 0.15^2) with d = ln 0.6 for the incubated group (a 40 % softer typical
specimen) and 0 for the fresh one; ln beta1 ~ N(ln 0.1, 0.2^2) in both groups (no effect); gamma1 = 0.5 for all
(the relaxed fraction; a specimen-level parameter in the fit). Protocol: a ramp to stretch 1.05 in 8.6 s held to
60 s, a sample every 0.5 s, noise sd 5 mN (seed below). Specimen size as in ``tendon_relaxation``.

    python studies/make_tendon_groups.py       # rewrites the directory
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from bayestissue.io.tables import write_table
from bayestissue.mechanics import load_experiment, simulate

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "synthetic" / "tendon_groups"
SEED = 20261128
NOISE_SD_MN = 5.0
FIXED = {"mu": 10.0, "kappa": 10.0, "k2_1": 2.0, "disp1": 0.02, "lamr1": 1.01, "gamma1": 0.5}
POPULATION = {"k1_1": (math.log(5.0e4), 0.15), "beta1": (math.log(0.1), 0.2)}
EFFECT = {"incubated": {"k1_1": math.log(0.6)}}
GROUPS = ("fresh",) * 4 + ("incubated",) * 4
SIDE = math.sqrt(math.pi * 0.376**2 / 4.0)


def experiment_toml(name: str, group: str, truth: dict, data: str | None) -> str:
    source = f'file = "{data}"' if data else "duration_s = 60.0\nstep_s = 0.5"
    values = ", ".join(f"{k}={v:.6g}" for k, v in truth.items())
    return f"""# SYNTHETIC: written by studies/make_tendon_groups.py (no measured data); generating values: {values}
name = "{name}"
description = "SYNTHETIC tendon relaxation, group {group}: ramp to 5 % in 8.6 s, held to 60 s"
synthetic = true

[specimen]
length_x_mm = 14.33
length_y_mm = {SIDE!r}
length_z_mm = {SIDE!r}

[protocol]
kind = "stretch_ramp"
stretch = 1.05
ramp_s = 8.6

[simulation]
dt_s = 0.5

[tissue]
preset = "tendon"
fibre = "hgo"
recruitment = true
fibre_branches = 1

[data]
{source}
"""


FIT = """# Stage-1 calibration of every specimen of data/synthetic/tendon_groups (SYNTHETIC): the known values held,
# k1_1, gamma1 and beta1 sampled under the box priors (the broad stage-1 prior of the two-stage model).
[parameters]
fixed = { mu = 10.0, kappa = 10.0, k2_1 = 2.0, disp1 = 0.02, lamr1 = 1.01 }

[warmstart]
n_starts = 4

[sampler]
seed = 20261128
"""


def specimens_toml(names) -> str:
    lines = ["# SYNTHETIC two-group tendon study (studies/make_tendon_groups.py): the specimens file of",
             "# `bayestissue hierarchy`. Generating population: see that script's docstring.",
             'fit_config = "fit.toml"', 'parameters = ["k1_1", "beta1"]', 'reference_group = "fresh"', "",
             "[population]", "seed = 1", ""]  # fmt: skip
    for name, group in zip(names, GROUPS, strict=True):
        lines += ["[[specimen]]", f'name = "{name}"', f'group = "{group}"', f'experiments = ["{name}.toml"]', ""]
    return "\n".join(lines)


def draw_truths(rng, groups=GROUPS, population=POPULATION, effect=EFFECT) -> list[dict]:
    """Each specimen's generating values: the population draws plus the fixed ones."""
    out = []
    for g in groups:
        t = dict(FIXED)
        for n, (m, s) in population.items():
            t[n] = float(np.exp(m + effect.get(g, {}).get(n, 0.0) + s * rng.standard_normal()))
        out.append(t)
    return out


def write_specimen(path_toml: Path, name: str, group: str, truth: dict, seed) -> None:
    """One specimen's experiment (TOML + CSV) from its generating values."""
    path_toml.write_text(experiment_toml(name, group, truth, None))
    exp = load_experiment(path_toml)
    run = simulate(exp, np.array([truth[n] for n in exp.tissue.param_names]), full=True)
    f = run.force_mN[0] + np.random.default_rng(seed).normal(0.0, NOISE_SD_MN, exp.time_s.size)
    f[0] = 0.0
    meta = {"synthetic": "yes -- simulated by this package's forward model, NOT measured data",
            "generator": "studies/make_tendon_groups.py",
            "generating_parameters": ", ".join(f"{k}={v:.6g}" for k, v in truth.items()),
            "seed": str(seed), "noise_sd_mN": str(NOISE_SD_MN)}  # fmt: skip
    write_table(path_toml.with_suffix(".csv"), {"time_s": exp.time_s, "displacement_mm": run.displacement_mm[0],
                                                "force_mN": f}, meta=meta)  # fmt: skip
    path_toml.write_text(experiment_toml(name, group, truth, path_toml.with_suffix(".csv").name))
    load_experiment(path_toml)


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    truths = draw_truths(rng)
    names = [f"{g}_{k % 4 + 1}" for k, g in enumerate(GROUPS)]
    for k, (name, group, truth) in enumerate(zip(names, GROUPS, truths, strict=True)):
        write_specimen(OUT / f"{name}.toml", name, group, truth, SEED + 1 + k)
    (OUT / "fit.toml").write_text(FIT)
    (OUT / "specimens.toml").write_text(specimens_toml(names))
    for name, t in zip(names, truths, strict=True):
        print(f"{name}: k1_1 {t['k1_1']:.4g} kPa, beta1 {t['beta1']:.4g} 1/s")
    print(f"wrote {OUT}/ ({len(names)} specimens, specimens.toml, fit.toml)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

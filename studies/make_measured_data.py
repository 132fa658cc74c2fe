"""Bundle the measured curves of ../shared/external as experiment files in data/measured/ (run once; the study reads
the bundled copies, never ../shared).

Treloar (1944) rubber in equibiaxial tension and pure shear, Budday et al. (2017) brain tissue in uniaxial
compression (basal ganglia, corpus callosum) and simple shear (also the cortex), beside the uniaxial tension files
already bundled. Each CSV carries the citation, the source and the MIT licence notice of the digitised tables
(LICENSE-Hyperelastic-fitting.txt); changed from the source: the column names, Treloar's MPa to kPa (x 1000, 10
significant digits), a first row at the reference state (stretch 1 or shear 0, stress 0) left out, and a time_s
column, the point's index (the data are quasi-static; the elastic laws fitted to them only order the points).

    python studies/make_measured_data.py [--source ../shared/external] [--out data/measured]
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CITATIONS = {
    "treloar": "L. R. G. Treloar, Stress-strain data for vulcanised rubber under various types of deformation, "
    "Trans. Faraday Soc. 40 (1944) 59-70",
    "budday": "S. Budday et al., Mechanical characterization of human brain tissue, Acta Biomaterialia 48 (2017) "
    "319-340",
}
LICENCE = "MIT (digitised tables from github.com/Chongran-Zhao/Hyperelastic-fitting). Copyright (c) 2024 Chongran Zhao."

#: (file stem, source file, citation key, mode, control, preset, description, source text)
CASES = (
    ("treloar_1944_equibiaxial", "treloar_1944/equibiaxial_tension.csv", "treloar", "equibiaxial", "stretch",
     "rubber", "vulcanised natural rubber, equibiaxial tension to stretch 4.45 (nominal stress, MPa to kPa: x 1000)",
     "nominal stress P11 = P22 along the two stretched axes against their stretch, P33 = 0"),
    ("treloar_1944_pure_shear", "treloar_1944/pure_shear.csv", "treloar", "pure_shear", "stretch", "rubber",
     "vulcanised natural rubber, pure shear (planar tension) to stretch 4.97 (nominal stress, MPa to kPa: x 1000)",
     "nominal stress P11 against the stretch along x, lambda_2 = 1 held, P33 = 0"),
    ("budday_2017_basal_ganglia_compression", "budday_2017_brain/basal_ganglia_uniaxial_compression.csv", "budday",
     "uniaxial", "stretch", "brain", "human brain tissue, basal ganglia, uniaxial compression to stretch 0.9 (kPa)",
     "nominal stress P11 (negative) against the stretch, lateral faces free"),
    ("budday_2017_corpus_callosum_compression", "budday_2017_brain/corpus_callosum_uniaxial_compression.csv",
     "budday", "uniaxial", "stretch", "brain",
     "human brain tissue, corpus callosum, uniaxial compression to stretch 0.9 (kPa)",
     "nominal stress P11 (negative) against the stretch, lateral faces free"),
    ("budday_2017_basal_ganglia_shear", "budday_2017_brain/basal_ganglia_simple_shear.csv", "budday",
     "simple_shear", "shear", "brain", "human brain tissue, basal ganglia, simple shear, gamma -0.2 to 0.2 (kPa)",
     "shear stress against the amount of shear"),
    ("budday_2017_corpus_callosum_shear", "budday_2017_brain/corpus_callosum_simple_shear.csv", "budday",
     "simple_shear", "shear", "brain", "human brain tissue, corpus callosum, simple shear, gamma -0.2 to 0.2 (kPa; "
     "the last point returns to -0.198, as published)", "shear stress against the amount of shear"),
    ("budday_2017_cortex_shear", "budday_2017_brain/cortex_simple_shear.csv", "budday", "simple_shear", "shear",
     "brain", "human brain tissue, cortex, simple shear, gamma -0.2 to 0.2 (kPa)",
     "shear stress against the amount of shear"),
)  # fmt: skip


def _rows(path: Path, scale: float):
    with path.open() as f:
        reader = csv.reader(f)
        next(reader)
        rows = [(float(a), float(b) * scale) for a, b in reader]
    if rows and rows[0][1] == 0.0 and rows[0][0] in (0.0, 1.0):
        rows = rows[1:]  # the reference state: the model reproduces it exactly
    return rows


def write_case(case, source: Path, out: Path, licence_text: str) -> Path:
    stem, src, cite, mode, control, preset, description, what = case
    scale = 1000.0 if "mpa" in (source / src).read_text().splitlines()[0] else 1.0
    rows = _rows(source / src, scale)
    x_col, y_col = ("shear", "shear_stress_kpa") if control == "shear" else ("stretch", "nominal_stress_kpa")
    header = [
        "measured: yes -- real published data, not produced by this project",
        f"material: {description}",
        f"citation: {CITATIONS[cite]}",
        f"source: digitised table of the publication in the public repository Chongran-Zhao/Hyperelastic-fitting "
        f"({src.split('/')[-1]} of ../shared/external), as {what}",
        f"licence: {LICENCE}",
        f"licence text: {licence_text}",
        "time_s: the point's index (1 s per point). The data are quasi-static and carry no time; the elastic laws "
        "fitted to them only order the points. A first row at the reference state is left out.",
        "generator: studies/make_measured_data.py",
    ]
    lines = [f"# {h}" for h in header] + [f"time_s,{x_col},{y_col}"]
    lines += [f"{i},{x:.10g},{y:.10g}" for i, (x, y) in enumerate(rows, start=1)]
    (out / f"{stem}.csv").write_text("\n".join(lines) + "\n")
    kind = "measured_shear" if control == "shear" else "measured_stretch"
    toml = f"""# Real measured data (see the CSV header and data/README.md for the source, citation and licence).
name = "{stem}"
description = "{description}"
synthetic = false

[specimen]                  # the data are stresses: a unit cube makes force (mN) = stress (kPa)
length_x_mm = 1.0
length_y_mm = 1.0
length_z_mm = 1.0

[protocol]
kind = "{kind}"
mode = "{mode}"

[simulation]
dt_s = 1.0                  # one step per data point (time_s is the point index; the laws fitted are elastic)

[data]
file = "{stem}.csv"

[tissue]                    # matrix only, nearly incompressible (K = 2 GPa): docs/presets.md
preset = "{preset}"
"""
    (out / f"{stem}.toml").write_text(toml)
    return out / f"{stem}.toml"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", type=Path, default=ROOT.parent / "shared" / "external")
    ap.add_argument("--out", type=Path, default=ROOT / "data" / "measured")
    args = ap.parse_args(argv)
    licence = " ".join((args.source / "LICENSE-Hyperelastic-fitting.txt").read_text().split())
    licence = licence.split("Permission is hereby granted", 1)[1]
    licence = "Permission is hereby granted" + licence
    for case in CASES:
        print("wrote", write_case(case, args.source, args.out, licence))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""``bayestissue import EXPORT.csv --out DIR``: a testing machine's raw export -> an experiment (TOML + tidy CSV).

The accepted shapes of the export: :mod:`bayestissue.io.machine_export`. The written experiment is loaded back
before the command reports success, so what it writes is what ``fit`` and ``simulate`` will read.
"""

from __future__ import annotations

import argparse
import hashlib
import re
from pathlib import Path

import numpy as np

from bayestissue.cli import plain
from bayestissue.io.export_prepare import DROP
from bayestissue.mechanics.presets import PRESETS

__all__ = ["register", "run"]

#: The default simulation step after resampling is at least the duration over this many steps.
MAX_DEFAULT_STEPS = 5000


def register(subparsers) -> None:
    from bayestissue.io import machine_export

    p = subparsers.add_parser(
        "import",
        help="turn a testing machine's CSV export into an experiment (TOML + tidy CSV)",
        description=plain(machine_export.__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("export", help="the machine's CSV export")
    p.add_argument("--out", required=True, help="folder for <name>.toml and <name>.csv")
    p.add_argument("--name", help="experiment name (default: the export's specimen label, else its file stem)")
    p.add_argument(
        "--control",
        choices=("stretch", "force"),
        default="stretch",
        help="stretch (default): the measured extension is prescribed and the force observed; force: the measured "
        "force is the load and the extension observed",
    )
    p.add_argument("--tissue", choices=sorted(PRESETS), default="slug",
                   help="tissue preset (docs/presets.md): slug, the paper's three fibre families (default); tendon, "
                   "one family along the load; brain and rubber, matrix only; each with its boxes")  # fmt: skip
    p.add_argument("--bulk-kpa", type=float, help="bulk modulus of the volumetric penalty (default: the preset's)")
    p.add_argument("--gauge-mm", type=float, help="gauge length (overrides the export's)")
    p.add_argument("--diameter-mm", type=float, help="diameter of a round specimen (overrides the export's)")
    p.add_argument("--width-mm", type=float, help="width (with --thickness-mm; overrides the export's)")
    p.add_argument("--thickness-mm", type=float, help="thickness (with --width-mm)")
    p.add_argument("--until-s", type=float, help="drop the samples after this time (s)")
    p.add_argument("--drop", type=float, default=DROP,
                   help="failure or slip: a sudden fall of the load by more than this share of its peak within "
                   f"three samples (at least 0.1 s); a gradual relaxation is never cut (default {DROP})")  # fmt: skip
    p.add_argument("--no-failure-cut", action="store_true", help="keep the samples after a failure")
    p.add_argument(
        "--tare",
        action="store_true",
        help="subtract the preload (the load before the extension moves; default: keep it, and say so)",
    )
    p.add_argument("--step-s", type=float,
                   help="thin the data to as many samples as this step gives, denser where the load changes "
                   "(default: keep every sample)")  # fmt: skip
    p.add_argument("--dt-s", type=float,
                   help="simulation step (default: the data's median step; after --step-s, the smallest step kept, "
                   f"at least the duration / {MAX_DEFAULT_STEPS})")  # fmt: skip
    p.add_argument("--overwrite", action="store_true", help="replace existing files of the same name")
    p.set_defaults(func=run, outputs={"--out": ("out", "dir")})


def _positive(name: str, value):
    from bayestissue._validation import check_positive

    return None if value is None else check_positive(name, value)


def run(args) -> int:
    from bayestissue._validation import ValidationError
    from bayestissue.io.export_prepare import prepare
    from bayestissue.io.machine_export import block_section, read_machine_export
    from bayestissue.io.tables import write_table
    from bayestissue.mechanics import load_experiment

    for name in ("bulk_kpa", "gauge_mm", "diameter_mm", "width_mm", "thickness_mm", "until_s", "step_s", "dt_s"):
        _positive(f"--{name.replace('_', '-')}", getattr(args, name))
    if not (0.0 < args.drop < 1.0):
        raise ValidationError("--drop", args.drop, "a fraction of the peak load in (0, 1)")
    if (args.width_mm is None) != (args.thickness_mm is None):
        raise ValidationError("--width-mm/--thickness-mm", "one of them", "both or neither")
    export = read_machine_export(args.export)
    src = Path(args.export)
    gauge = args.gauge_mm or export.gauge_mm
    if gauge is None:
        raise ValidationError(f"{src.name} gauge length", "missing", "a 'Gauge length' line or --gauge-mm")
    if args.diameter_mm or args.width_mm:
        section, note = block_section(
            diameter_mm=args.diameter_mm, width_mm=args.width_mm, thickness_mm=args.thickness_mm
        )
    elif export.section_mm:
        section, note = export.section_mm, export.section_note
    else:
        raise ValidationError(
            f"{src.name} cross-section", "missing", "a 'Diameter' or 'Width' + 'Thickness' line, or --diameter-mm"
        )
    columns, notes = prepare(export, until_s=args.until_s, drop=None if args.no_failure_cut else args.drop,
                             tare=args.tare, step_s=args.step_s)  # fmt: skip
    trimming = "; ".join(notes) or "no trimming"
    name = re.sub(r"[^\w.-]", "_", args.name or export.label or src.stem)
    out = Path(args.out)
    toml_path, csv_path = out / f"{name}.toml", out / f"{name}.csv"
    for path in (toml_path, csv_path):
        if path.exists() and not args.overwrite:
            raise ValidationError(str(path), "an existing file", "a new file name (or --overwrite)")
    steps = np.diff(columns["time_s"])
    if args.dt_s:
        dt = args.dt_s
    elif args.step_s:
        dt = max(float(steps.min()), float(columns["time_s"][-1]) / MAX_DEFAULT_STEPS)
    else:
        dt = float(np.median(steps))
    if args.control == "stretch":
        observed, protocol = "force_mN", 'kind = "measured_stretch"   # the extension is prescribed'
    else:
        observed, protocol = "displacement_mm", 'kind = "measured"           # the force is the load'
    meta = {
        "measured": f"yes -- imported from a testing machine's export by bayestissue import ({observed} observed)",
        "imported from": f"{src.name} (sha256 {hashlib.sha256(src.read_bytes()).hexdigest()})",
        "specimen label": export.label or "none given",
        "cross-section": note,
        "original units": ", ".join(f"{k} {v}" for k, v in export.units.items()),
        "trimming": trimming,
    }
    lines = [
        f"# Imported by bayestissue import from {src.name}: {trimming}.",
        f'name = "{name}"',
        f'description = "{export.label or name}: imported machine export"',
        "synthetic = false",
        "",
        "[specimen]",
        f"length_x_mm = {gauge!r}      # gauge length",
        f"length_y_mm = {section[0]!r}   # {note}",
        f"length_z_mm = {section[1]!r}",
        "",
        "[protocol]",
        protocol,
        "",
        "[simulation]",
        f"dt_s = {dt!r}",
        "",
        "[data]",
        f'file = "{csv_path.name}"',
    ]
    if args.tissue != "slug" or args.bulk_kpa is not None:
        lines += ["", "[tissue]", f'preset = "{args.tissue}"']
        if args.bulk_kpa is not None:
            lines.append(f"bulk_kpa = {args.bulk_kpa!r}")
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    write_table(csv_path, columns, meta=meta)
    toml_path.write_text("\n".join(lines) + "\n")
    try:
        exp = load_experiment(toml_path)  # what fit and simulate will read
    except ValueError:
        toml_path.unlink()
        csv_path.unlink()
        if created:
            out.rmdir()  # a refused import leaves nothing behind
        raise
    for line, text in export.skipped:
        print(f"{src.name} line {line} skipped (not a metadata line this importer reads): {text[:80]}")
    print(f"wrote {toml_path} and {csv_path}: {exp.time_s.size} rows over {exp.time_s[-1]:g} s, "
          f"{args.control}-controlled ({exp.observable[0]} observed), simulation step {dt:.4g} s")  # fmt: skip
    for note in notes:
        print(f"  {note}")
    return 0

"""``bayestissue simulate EXPERIMENT --params name=value,... [--out CSV]``: the simulated curve of an experiment."""

from __future__ import annotations

from pathlib import Path

__all__ = ["register", "run"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "simulate",
        help="simulate an experiment file and print or write its displacement and force curves",
        description="Simulate EXPERIMENT (a TOML experiment file) with the given material parameters. "
        "Parameters not given keep the paper's initial guess (docs/model.md Table 1) for the slug tissue, or the "
        "middle of the tissue preset's boxes for any other tissue (docs/presets.md).",
    )
    p.add_argument("experiment", help="experiment file (TOML), e.g. data/T1.toml")
    p.add_argument(
        "--params",
        default="",
        help="comma-separated name=value pairs, e.g. mu=2.18,kappa=2.91 (names: mu, kappa, ginf1, gamma1, "
        "beta1, ..., beta3)",
    )
    p.add_argument(
        "--preset",
        choices=("initial", "T1", "T2"),
        default="initial",
        help="base parameter set: the paper's Table 1 (initial, T1, T2) for the slug tissue; for another tissue "
        "preset only 'initial', the middle of its boxes (default: initial)",
    )
    p.add_argument("--out", help="write a CSV (time_s, displacement_mm, force_mN) instead of printing")
    p.set_defaults(func=run, outputs={"--out": ("out", "file")})


def run(args) -> int:
    from bayestissue._validation import ValidationError
    from bayestissue.io.tables import write_table
    from bayestissue.mechanics import load_experiment, parse_parameters, simulate
    from bayestissue.mechanics.presets import preset
    from bayestissue.paper import PAPER_PARAMETERS

    exp = load_experiment(args.experiment)
    tissue = exp.tissue
    names = tissue.param_names
    if tissue.is_paper_model and len(names) == 11:
        base = PAPER_PARAMETERS[args.preset]
    elif args.preset != "initial":
        where = f"'initial' for the {tissue.preset} tissue of {Path(args.experiment).name}"
        raise ValidationError("--preset", args.preset, where, "T1 and T2 are the slug paper's parameter sets")
    else:  # the middle of the tissue preset's boxes (docs/presets.md), as the calibration's initial values
        box = preset(tissue.preset)
        base = [box.box(c, spec)[2] for spec, c in zip(tissue.parameters, tissue.components(), strict=True)]
    params = parse_parameters(args.params, tissue.parameters, base=base)
    run = simulate(exp, params, full=True)
    if not run.ok[0]:
        given = ", ".join(f"{n}={v:g}" for n, v in zip(names, params, strict=True))
        raise ValidationError("--params", args.params or args.preset, "parameters the model can be solved with",
                              f"no equilibrium was found for {given} (e.g. a matrix without stiffness, or a load "
                              "beyond what these parameters carry)")  # fmt: skip
    # both at the data times, interpolated alike (Experiment.interpolation: a data time inside the first step takes
    # step 1, where the load is applied); one is prescribed, the other computed
    u, force = run.displacement_mm[0], run.force_mN[0]
    meta = {
        "experiment": exp.source,
        "parameters": ", ".join(f"{n}={v:g}" for n, v in zip(names, params, strict=True)),
        "simulated": "yes -- model output, not data",
    }
    columns = {"time_s": exp.time_s, "displacement_mm": u, "force_mN": force}
    if args.out:
        write_table(args.out, columns, meta=meta)
        print(f"wrote {args.out} ({u.size} rows)")
    else:
        for k, v in meta.items():
            print(f"# {k}: {v}")
        print("time_s,displacement_mm,force_mN")
        for row in zip(*columns.values(), strict=True):
            print(",".join(f"{x:.10g}" for x in row))
    return 0

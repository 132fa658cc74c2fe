"""``bayestissue hierarchy SPECIMENS.toml --out DIR [--resume]``: specimens and groups, the two-stage hierarchical
model.

Stage 1 calibrates every specimen alone (``DIR/specimens/<name>/``, as ``bayestissue fit`` would); stage 2 samples
the population from their draws: each group effect with its 90 % interval and P(> 0), the population sd, each
specimen's shrunken estimate beside its own fit and a new specimen's range per group. Writes
``hierarchy_summary.md``/``.csv``, ``hierarchy.nc`` and ``hierarchy.png`` into DIR. The specimens file's keys:
docs/hierarchy.md. ``--workers N`` / ``--scheduler ADDRESS``: the specimens' stage-1 fits as dask tasks (a local
cluster of N workers, or a running one whose workers share DIR's file system), each fit in one process.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

__all__ = ["register", "run"]

#: ``--quick``: stage 2 shortened (stage 1 takes ``bayestissue fit --quick``'s settings).
QUICK_POPULATION = {"chains": 2, "warmup": 200, "draws": 400}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "hierarchy",
        help="specimens and groups: group effects, population sd and a new specimen's range (two-stage model)",
        description=__doc__.splitlines()[0].split(": ", 1)[1],
    )
    p.add_argument("specimens", metavar="SPECIMENS", help="specimens file (TOML; keys: docs/hierarchy.md)")
    p.add_argument("--out", required=True, help="output directory")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--resume", action="store_true",
                      help="read back the specimens finished in --out, continue the others")  # fmt: skip
    mode.add_argument("--overwrite", action="store_true", help="replace the specimens' runs in --out")
    p.add_argument("--quick", action="store_true",
                   help="smoke run: stage 1 as fit --quick, a short stage 2; not converged")  # fmt: skip
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N",
                       help="stage 1 as tasks of a local dask cluster of N single-process workers")  # fmt: skip
    where.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="stage 1 as tasks of a running dask cluster, tcp://host:8786 (docs/cluster.md)",
    )
    p.add_argument("--no-figures", action="store_true", help="do not draw the figure")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run, outputs={"--out": ("out", "dir")})


def run(args) -> int:
    from bayestissue._validation import ValidationError
    from bayestissue.cli.fit import QUICK_NESTED, QUICK_SAMPLER, _progress
    from bayestissue.parallel import is_scheduler_address
    from bayestissue.workflows import load_config
    from bayestissue.workflows.hierarchy import load_hierarchy, run_hierarchy
    from bayestissue.workflows.hierarchy_summary import write_hierarchy

    t0 = time.perf_counter()
    if args.workers is not None and args.workers < 1:
        raise ValidationError("--workers", args.workers, "an integer >= 1")
    if args.scheduler is not None and not is_scheduler_address(args.scheduler):
        raise ValidationError("--scheduler", args.scheduler, "a scheduler address like tcp://host:8786")
    spec = load_hierarchy(args.specimens)
    over = {}
    if args.quick:
        over.update(n_starts=2, ls_max_nfev=200, sampler=QUICK_SAMPLER, nested=QUICK_NESTED)
        spec = replace(spec, population={**spec.population, **QUICK_POPULATION})
    config = load_config(spec.fit_config, **over)
    out = Path(args.out)
    print(f"{len(spec.specimens)} specimens in groups {', '.join(spec.groups)} (reference {spec.groups[0]}); "
          f"population parameters {', '.join(spec.parameters)}")  # fmt: skip
    bars = None if args.no_progress else (lambda: _progress(config, enabled=True))
    client = None
    if args.workers is not None or args.scheduler is not None:
        import logging

        from bayestissue.parallel import start_client

        logging.getLogger("distributed").setLevel(logging.WARNING)  # the cluster's start-up chatter
        client = start_client(args.scheduler, n_workers=args.workers)
    try:
        outcome = run_hierarchy(spec, config, out, resume=args.resume, overwrite=args.overwrite,
                                config_path=spec.fit_config, progress=bars, client=client,
                                say=lambda line: print(line, flush=True))  # fmt: skip
    finally:
        if client is not None:
            cluster = client.cluster if args.scheduler is None else None
            client.close()
            if cluster is not None:
                cluster.close()
    print(write_hierarchy(outcome, out, figures=not args.no_figures))
    print(f"wrote {out}/ in {time.perf_counter() - t0:.1f} s")
    return 0

"""Specimens and groups (issue 35): the two-stage hierarchical model on a synthetic two-group tendon study, and on
the slug replicas T1 and T2 as two specimens of one tissue.

* Tendon groups (``data/synthetic/tendon_groups``, 4 fresh + 4 incubated specimens drawn from a known population):
  stage 1 calibrates each specimen alone (``fit.toml`` there; runs in ``runs/hierarchy/tendon_groups``), stage 2 the
  population of k1_1 and beta1: the group effects, the population sds, the shrunken specimens, a new specimen's
  range, against the generating values.
* T1 and T2 as two specimens: stage 2 from the calibration stage's mirror-model posteriors
  (``calibration_T{1,2}_mirror_posterior.nc`` in --out; skipped without them) for the fibre family-2 law:
  how much of their difference a population sd absorbs, with the plain statement that two specimens give the sd one
  degree of freedom.

Writes into --out: ``hierarchy_<case>.png``, ``hierarchy_<case>_summary.md``/``.csv`` and ``hierarchy_record.json``
(read by the report's section 8).

    python studies/specimens.py [--quick | --full] [--out DIR]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from bayestissue.analyses.calibration_study import study_config
from bayestissue.analyses.hierarchy_record import hierarchy_case
from bayestissue.analyses.records import FILES, HierarchyRecord
from bayestissue.inference.hierarchy import sample_population
from bayestissue.io.records import write_record
from bayestissue.io.results import read_inference_data
from bayestissue.mechanics import load_experiment
from bayestissue.workflows import config_from_mapping, load_config
from bayestissue.workflows.hierarchy import (
    HierarchyOutcome,
    HierarchySpec,
    SpecimenEntry,
    load_hierarchy,
    population_diagnostics,
    run_hierarchy,
)
from bayestissue.workflows.hierarchy_summary import write_hierarchy
from bayestissue.workflows.problem import build_problem

ROOT = Path(__file__).resolve().parents[1]
GROUPS = ROOT / "data" / "synthetic" / "tendon_groups" / "specimens.toml"
#: T1 and T2 as specimens: the fibre family-2 modulus and rate (identified by T1; T2 sees ginf2, little of beta2). The
#: other parameters are each test's own: a population over parameters neither test identifies is its prior.
SLUG_PARAMETERS = ("ginf2", "beta2")
#: stage 1 (calibration overrides) and stage 2 (``[population]``) per mode; quick: bayestissue fit --quick's stage 1
SETTINGS = {
    "quick": {"stage1": {"n_starts": 2, "ls_max_nfev": 200,
                         "sampler": {"max_steps": 300, "check_every": 100, "prune_rounds": 1, "prune_steps": 50,
                                     "adapt_rounds": 1, "adapt_steps": 100}},
              "population": {"chains": 2, "warmup": 200, "draws": 400}},
    "default": {"stage1": {}, "population": {"chains": 4, "warmup": 1000, "draws": 2000}},
    "full": {"stage1": {}, "population": {"chains": 4, "warmup": 4000, "draws": 10000}},
}  # fmt: skip


def tendon_groups(key: str, out: Path) -> object:
    t0 = time.perf_counter()
    spec = load_hierarchy(GROUPS)
    spec = replace(spec, population={**spec.population, **SETTINGS[key]["population"]})
    config = load_config(spec.fit_config, **SETTINGS[key]["stage1"])
    runs = ROOT / "runs" / "hierarchy" / ("tendon_groups_quick" if key == "quick" else "tendon_groups")
    outcome = run_hierarchy(spec, config, runs, overwrite=True, config_path=spec.fit_config, say=print)
    print(write_hierarchy(outcome, out, stem="hierarchy_tendon_groups", draws=False))
    verdicts = {n: v.split(":")[0] for n, v in zip(outcome.posterior.specimens, outcome.verdicts, strict=True)}
    return hierarchy_case("tendon_groups", "Synthetic tendon study: 4 fresh and 4 incubated specimens",
                          outcome.posterior, outcome.stage1, diagnostics=outcome.diagnostics, notes=outcome.notes,
                          stage1_verdicts=verdicts, figure="hierarchy_tendon_groups.png",
                          seconds=time.perf_counter() - t0, generating=outcome.generating,
                          terms=outcome.tissue_terms)  # fmt: skip


def slug_specimens(key: str, out: Path) -> object | None:
    """T1 and T2 as two specimens of one group, from the calibration stage's mirror posteriors."""
    from bayestissue.workflows.hierarchy import design_notes

    t0 = time.perf_counter()
    paths = [out / f"calibration_{t}_mirror_posterior.nc" for t in ("T1", "T2")]
    if not all(p.is_file() for p in paths):
        print(f"T1/T2 as two specimens: skipped (no {paths[0].name} / {paths[1].name} in {out})")
        return None
    exp = load_experiment(ROOT / "data" / "T1.toml")
    material = build_problem([exp], config_from_mapping(None, **study_config("default", "mirror", "T1"))).material
    names = SLUG_PARAMETERS
    stage1, verdicts = [], {}
    for label, path in zip(("T1", "T2"), paths, strict=True):
        post = read_inference_data(path).posterior
        stage1.append(np.column_stack([post[n].values.reshape(-1) for n in names]))
        verdicts[label] = str(post.attrs.get("convergence", "")).split(":")[0]
    pop = SETTINGS[key]["population"]
    specs = [material.sampled[material.sampled_names.index(n)] for n in names]
    post = sample_population(stage1, specs, ["slug", "slug"], specimens=["T1", "T2"],
                             n_chains=pop["chains"], n_warmup=pop["warmup"], n_draws=pop["draws"], seed=1)  # fmt: skip
    spec = HierarchySpec(paths[0], (SpecimenEntry("T1", "slug", ()), SpecimenEntry("T2", "slug", ())), names)
    outcome = HierarchyOutcome(spec, stage1, list(verdicts.values()), ["", ""], post, design_notes(spec),
                               population_diagnostics(post))  # fmt: skip
    print(write_hierarchy(outcome, out, stem="hierarchy_T1_T2", draws=False))
    return hierarchy_case("T1_T2", "Slug replicas T1 and T2 as two specimens of one tissue", post, stage1,
                          diagnostics=outcome.diagnostics, notes=outcome.notes, stage1_verdicts=verdicts,
                          figure="hierarchy_T1_T2.png", seconds=time.perf_counter() - t0)  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="smoke run (short stage-1 chains, short stage 2)")
    mode.add_argument("--full", action="store_true", help="longer stage 2")
    ap.add_argument("--out", type=Path, default=ROOT / "figures")
    args = ap.parse_args(argv)
    key = "quick" if args.quick else "full" if args.full else "default"
    args.out.mkdir(parents=True, exist_ok=True)
    cases = [tendon_groups(key, args.out)]
    slug = slug_specimens(key, args.out)
    if slug is not None:
        cases.append(slug)
    write_record(args.out / FILES[HierarchyRecord], HierarchyRecord(mode=key, cases=cases))
    print(f"wrote {args.out / FILES[HierarchyRecord]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

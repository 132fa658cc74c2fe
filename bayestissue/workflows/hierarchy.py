"""Specimens and groups: ``bayestissue hierarchy SPECIMENS.toml --out DIR``, the two-stage hierarchical model.

Stage 1 calibrates every specimen on its own experiments with one calibration configuration (the box priors are the
broad stage-1 prior), each in its own run directory ``DIR/specimens/<name>/`` (locked, checkpointed, resumable like
``bayestissue fit``); stage 2 samples the population from their posterior draws without a forward solve
(:mod:`bayestissue.inference.hierarchy`). The specimens file::

    fit_config = "fit.toml"            # optional: stage 1's configuration (paths relative to this file)
    parameters = ["k1_1", "beta1"]     # the population parameters (sampled in stage 1)
    reference_group = "fresh"          # optional: effects are relative to it (default: the first specimen's)

    [population]                       # optional: stage 2
    chains = 4
    warmup = 1000
    draws = 2000
    proposals = 5
    seed = 1
    sd_scale = { k1_1 = 1.0 }          # half-normal scale of a population sd (default: box width / 4)
    effect_scale = { k1_1 = 1.0 }      # sd of a group effect's prior (default: box width / 4)
    strain = 0.03                      # nominal strain of the tissue terms (default: the smallest test's largest)

    [[specimen]]
    name = "A"
    group = "fresh"
    experiments = ["A_relax.toml"]

Every specimen's sampled parameters must be the same (one model); the other sampled parameters are each specimen's
own (stage 1 integrates them out); fixed and tied ones stay as the configuration says.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError, check_known_keys

__all__ = ["HierarchySpec", "HierarchyOutcome", "load_hierarchy", "run_hierarchy", "design_notes", "fit_specimen"]

_TOP = ("fit_config", "parameters", "reference_group", "population", "specimen")
_POPULATION = ("chains", "warmup", "draws", "proposals", "seed", "sd_scale", "effect_scale", "strain")
_SPECIMEN = ("name", "group", "experiments")


@dataclass(frozen=True)
class SpecimenEntry:
    name: str
    group: str
    experiments: tuple[Path, ...]


@dataclass(frozen=True)
class HierarchySpec:
    """A parsed, checked specimens file (module docstring)."""

    source: Path
    specimens: tuple[SpecimenEntry, ...]
    parameters: tuple[str, ...]
    fit_config: Path | None = None
    reference_group: str | None = None
    population: dict = field(default_factory=dict)

    @property
    def groups(self) -> tuple[str, ...]:
        ref = self.reference_group or self.specimens[0].group
        return (ref, *sorted({s.group for s in self.specimens} - {ref}))


def _int_option(where, key, value, low):
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValidationError(f"{where} [population] {key}", value, f"an integer >= {low}")
    return value


def load_hierarchy(path: str | Path) -> HierarchySpec:
    """Read and check a specimens file: known keys (nearest valid name), unique specimen names, existing experiment
    files, at least two specimens, a known reference group; raises ``ValidationError`` naming file and field."""
    from bayestissue.io.results import read_config

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"specimens file {path}: no such file")
    where = path.name
    raw = read_config(path)
    check_known_keys(f"{where}: key", raw, _TOP)
    base = path.parent
    params = raw.get("parameters")
    if not isinstance(params, list) or not params or not all(isinstance(p, str) for p in params):
        raise ValidationError(f"{where}: parameters", params, "a non-empty list of parameter names")
    entries = raw.get("specimen")
    if not isinstance(entries, list) or len(entries) < 2:
        raise ValidationError(f"{where}: [[specimen]]", entries if entries is None else len(entries),
                              "two or more [[specimen]] tables")  # fmt: skip
    specimens, seen = [], set()
    for k, e in enumerate(entries, 1):
        if not isinstance(e, Mapping):
            raise ValidationError(f"{where}: specimen {k}", e, "a table with name, group, experiments")
        check_known_keys(f"{where}: specimen {k} key", e, _SPECIMEN)
        name, group, exps = e.get("name"), e.get("group"), e.get("experiments")
        if not isinstance(name, str) or not name.isidentifier():
            raise ValidationError(f"{where}: specimen {k} name", name, "a name of letters, digits and _")
        if name in seen:
            raise ValidationError(f"{where}: specimen {k} name", name, "a name no other specimen has")
        seen.add(name)
        if not isinstance(group, str) or not group:
            raise ValidationError(f"{where}: specimen {name} group", group, "a group name")
        if not isinstance(exps, list) or not exps or not all(isinstance(x, str) for x in exps):
            raise ValidationError(f"{where}: specimen {name} experiments", exps, "a non-empty list of TOML files")
        files = tuple(base / x for x in exps)
        for f in files:
            if not f.is_file():
                raise ValidationError(f"{where}: specimen {name} experiments", str(f), "an existing experiment file")
        specimens.append(SpecimenEntry(name, group, files))
    ref = raw.get("reference_group")
    if ref is not None and ref not in {s.group for s in specimens}:
        raise ValidationError(f"{where}: reference_group", ref,
                              f"one of the specimens' groups {sorted({s.group for s in specimens})}")  # fmt: skip
    fit = raw.get("fit_config")
    if fit is not None and not (base / fit).is_file():
        raise ValidationError(f"{where}: fit_config", str(base / fit), "an existing configuration file")
    pop = dict(raw.get("population", {}))
    check_known_keys(f"{where}: [population] key", pop, _POPULATION)
    for key, low in (("chains", 2), ("warmup", 0), ("draws", 100), ("proposals", 1), ("seed", 0)):
        if key in pop:
            _int_option(where, key, pop[key], low)
    strain = pop.get("strain")
    if strain is not None and (isinstance(strain, bool) or not isinstance(strain, int | float) or not 0 < strain < 2):
        raise ValidationError(f"{where}: [population] strain", strain, "a nominal strain in (0, 2)")
    for key in ("sd_scale", "effect_scale"):
        table = pop.get(key, {})
        if not isinstance(table, Mapping):
            raise ValidationError(f"{where}: [population] {key}", table, "a table of parameter = scale")
        check_known_keys(f"{where}: [population] {key}", table, params)
        for n, v in table.items():
            if isinstance(v, bool) or not isinstance(v, int | float) or not v > 0:
                raise ValidationError(f"{where}: [population] {key}.{n}", v, "a positive number")
    return HierarchySpec(path, tuple(specimens), tuple(params), None if fit is None else base / fit, ref, pop)


def design_notes(spec: HierarchySpec) -> list[str]:
    """Plain statements of what the design cannot answer (before any work)."""
    notes = []
    counts = {g: sum(s.group == g for s in spec.specimens) for g in spec.groups}
    for g, n in counts.items():
        if n == 1:
            notes.append(f"group {g!r} has one specimen: its effect is confounded with that specimen's own deviation "
                         "from its group, so the interval of the effect is set by the prior of the population sd, "
                         "not by the data")  # fmt: skip
    dof = sum(n - 1 for n in counts.values())  # specimens minus groups
    if dof == 0:
        notes.append("no group has two specimens: the population sd is not identified by these data (prior-driven)")
    elif dof < 3:
        notes.append(f"{dof} degree{'s' if dof > 1 else ''} of freedom for the population sd (specimens minus "
                     "groups): its interval is wide and its prior matters")  # fmt: skip
    return notes


@dataclass
class HierarchyOutcome:
    """Stage 1 (per specimen: its draws of the population parameters, its verdict and predictive check) and stage 2
    (:class:`~bayestissue.inference.hierarchy.HierarchyPosterior`)."""

    spec: HierarchySpec
    stage1: list[np.ndarray]
    verdicts: list[str]
    fit_checks: list[str]
    posterior: object
    notes: list[str]
    diagnostics: dict
    generating: dict | None = None  # population parameter -> per specimen generating value (synthetic data)
    tissue_terms: object = None  # :class:`~bayestissue.workflows.population_terms.PopulationTerms`, or None


def _stage1_draws(post, names) -> tuple[np.ndarray, str, str]:
    """A specimen's draws of ``names`` from its posterior group, with its verdict and predictive check."""
    draws = np.column_stack([post[n].values.reshape(-1) for n in names])
    return draws, str(post.attrs.get("convergence", "")), str(post.attrs.get("fit_check", ""))


def run_hierarchy(
    spec: HierarchySpec,
    config,
    out_dir: str | Path,
    *,
    resume: bool = False,
    overwrite: bool = False,
    config_path=None,
    progress: Callable | None = None,
    say: Callable[[str], None] | None = None,
    client=None,
) -> HierarchyOutcome:
    """Stage 1 for every specimen (each in ``out_dir/specimens/<name>``; with ``resume`` a finished specimen is read
    back, not refitted), then stage 2. Every specimen's model is checked (same sampled parameters, the population
    parameters among them, orderings kept whole) before the first fit. ``progress()``, if given, returns a fresh
    sampling progress callback and its closing function for each specimen. With a dask ``client`` the specimens'
    stage-1 fits are its tasks (:func:`_stage1_on_cluster`)."""
    from bayestissue.inference.hierarchy import check_population_parameters, sample_population
    from bayestissue.mechanics import load_experiment
    from bayestissue.workflows.population_terms import population_terms
    from bayestissue.workflows.problem import build_problem

    say = say or (lambda line: None)
    if not config.sample:
        raise ValidationError("stage 1", "sample = false", "a sampled calibration (stage 2 needs posterior draws)")
    where = spec.source.name
    experiments = {s.name: [load_experiment(p) for p in s.experiments] for s in spec.specimens}
    problems = {}
    for s in spec.specimens:
        try:
            problems[s.name] = build_problem(experiments[s.name], config)
        except ValidationError as exc:
            raise exc.within(f"{where}: specimen {s.name}:") from None
    first = spec.specimens[0].name
    names = problems[first].material.sampled_names
    for s in spec.specimens[1:]:
        other = problems[s.name].material.sampled_names
        if other != names:
            raise ValidationError(f"{where}: specimen {s.name} model", ", ".join(other),
                                  f"the sampled parameters of specimen {first}: {', '.join(names)}")  # fmt: skip
    pset = problems[first].material
    check_population_parameters(spec.parameters, names, pset.ordered, field=f"{where}: parameters")
    notes = design_notes(spec)
    for n in notes:
        say(f"design: {n}")
    cols = [names.index(n) for n in spec.parameters]
    jobs = [(experiments[s.name], Path(out_dir) / "specimens" / s.name) for s in spec.specimens]
    common = {"names": names, "resume": resume, "overwrite": overwrite, "config_path": config_path}
    if client is None:
        results = []
        for k, (s, (exps, sub)) in enumerate(zip(spec.specimens, jobs, strict=True), 1):
            say(f"specimen {s.name} ({k}/{len(jobs)}, group {s.group}): stage 1")
            results.append(fit_specimen(exps, config, sub, progress=progress, say=say, **common))
            say(f"specimen {s.name}: {results[-1][3]}")
    else:
        results = _stage1_on_cluster(client, spec, jobs, config, common, say)
    stage1 = [r[0][:, cols] for r in results]
    full = [r[0] for r in results]
    verdicts = [r[1] for r in results]
    checks = [r[2] for r in results]
    pop = spec.population
    specs = [pset.sampled[names.index(n)] for n in spec.parameters]
    say(f"stage 2: population of {len(spec.specimens)} specimens in {len(spec.groups)} groups, "
        f"{pop.get('chains', 4)} chains")  # fmt: skip
    post = sample_population(
        stage1,
        specs,
        [s.group for s in spec.specimens],
        reference=spec.groups[0],
        specimens=[s.name for s in spec.specimens],
        sd_scale=pop.get("sd_scale"),
        effect_scale=pop.get("effect_scale"),
        n_chains=pop.get("chains", 4),
        n_warmup=pop.get("warmup", 1000),
        n_draws=pop.get("draws", 2000),
        n_proposals=pop.get("proposals", 5),
        seed=pop.get("seed", 0),
    )
    truth = _generating(experiments, spec)
    virtual = [(experiments[s.name][0], problems[s.name].material.expand) for s in spec.specimens]
    try:
        terms = population_terms(post, full, cols, virtual, strain=pop.get("strain"), seed=pop.get("seed", 0))
    except ValidationError as exc:
        say(f"tissue terms of the population: not computed ({exc})")
        terms = None
    return HierarchyOutcome(spec, stage1, verdicts, checks, post, notes, population_diagnostics(post), truth, terms)


def fit_specimen(experiments, config, sub, *, names, resume=False, overwrite=False, config_path=None, progress=None,
                 say=None) -> tuple[np.ndarray, str, str, str]:  # fmt: skip
    """Stage 1 of one specimen in its run directory ``sub``: with ``resume`` a finished run is read back (its
    manifest must match), an unfinished one continued; else a new calibration (``overwrite`` replaces an old one).
    Returns its draws of the sampled ``names`` (natural units), its verdict, its predictive check and what was done."""
    from bayestissue.io.results import read_inference_data
    from bayestissue.workflows.calibration import run_calibration
    from bayestissue.workflows.run_directory import open_run_directory, run_manifest, run_status

    manifest = run_manifest(config, experiments, config_path=config_path)
    status = run_status(sub)
    if resume and status == "finished" and (sub / "posterior.nc").is_file():
        with open_run_directory(sub, manifest, resume=True):  # refuses a different run
            pass
        post, how = read_inference_data(sub / "posterior.nc").posterior, "finished before, read back"
    else:
        bar, close = progress() if progress is not None else (None, lambda: None)
        again = resume and status is not None
        try:
            with open_run_directory(sub, manifest, resume=again, overwrite=overwrite):
                fitted = run_calibration(experiments, config, out_dir=sub, resume=again, progress=bar, say=say)
        finally:
            close()
        post, how = fitted.idata.posterior, "calibrated"
    draws, verdict, check = _stage1_draws(post, names)
    return draws, verdict, check, f"{how}, {verdict.split(':')[0]}"


def _stage1_on_cluster(client, spec, jobs, config, common, say) -> list:
    """Every specimen's :func:`fit_specimen` as one task of the dask ``client``, each in one process (its ensembles or
    runs one after another: the cluster's workers are the parallelism). The run directories must be on a file system
    the workers share with this process (a LocalCluster's are). Every task runs to its end; then the first error, if
    any, is raised (the finished specimens are read back by ``--resume``)."""
    from dask.distributed import as_completed

    serial = replace(config, sampler=replace(config.sampler, n_processes=1, scheduler=None),  # runs stay in the task
                     nested=replace(config.nested, n_processes=1, scheduler=None))  # fmt: skip
    futures = {client.submit(fit_specimen, exps, serial, sub, pure=False, **common): s
               for s, (exps, sub) in zip(spec.specimens, jobs, strict=True)}  # fmt: skip
    say(f"stage 1: {len(futures)} specimens as tasks of {client}")
    errors, results = [], {}
    for k, fut in enumerate(as_completed(futures), 1):
        s = futures[fut]
        if fut.status == "error":
            errors.append(fut.exception())
            say(f"specimen {s.name} ({k}/{len(futures)}): failed: {errors[-1]}")
        else:
            results[s.name] = fut.result()
            say(f"specimen {s.name} ({k}/{len(futures)}): {results[s.name][3]}")
    if errors:
        raise errors[0]
    return [results[s.name] for s in spec.specimens]


def _generating(experiments, spec) -> dict | None:
    """The generating values of the population parameters per specimen when every specimen's (first) data file
    states them (synthetic data), else None."""
    from bayestissue.workflows.problem import reference_values

    out = {n: [] for n in spec.parameters}
    for s in spec.specimens:
        first = experiments[s.name][0]
        gen = reference_values(first).get("generating")
        if gen is None:
            return None
        for n in spec.parameters:
            out[n].append(float(gen[list(first.tissue.param_names).index(n)]))
    return {n: np.array(v) for n, v in out.items()}


def population_diagnostics(post) -> dict:
    """R-hat (rank-normalised) and bulk ESS of every population quantity (arviz); the verdict CONVERGED needs
    R-hat < 1.01 and bulk ESS >= 400 for all of them (Vehtari et al. 2021)."""
    import arviz as az

    rows = {}
    for j, n in enumerate(post.scale.names):
        rows[f"m[{n}]"] = post.m[:, :, j]
        rows[f"s[{n}]"] = post.s[:, :, j]
        for g in range(1, len(post.groups)):
            rows[f"d[{post.groups[g]}, {n}]"] = post.d[:, :, g - 1, j]
    rhat = {k: float(az.rhat(v)) for k, v in rows.items()}
    ess = {k: float(az.ess(v)) for k, v in rows.items()}
    ok = max(rhat.values()) < 1.01 and min(ess.values()) >= 400
    worst = min(ess, key=ess.get)
    text = (f"{'CONVERGED' if ok else 'NOT CONVERGED'}: max R-hat {max(rhat.values()):.3f}, min bulk ESS "
            f"{ess[worst]:.0f} ({worst}); needs R-hat < 1.01 and ESS >= 400")  # fmt: skip
    return {"rhat": rhat, "ess": ess, "converged": ok, "verdict": text}

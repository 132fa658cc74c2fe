"""Which model the study uses, chosen by the evidence: the paper's 11 parameters against the mirror model (issue 36).

The paper's model has three fibre families with their own parameters; the mirror model ties family 3 to family 2
(:data:`bayestissue.paper.MIRROR_TIES`: the two families symmetric about the load axis, 8 sampled parameters). Both are
run through the nested engine on the same data with the same box prior and the noise sd integrated out, and the log
Bayes factor of the mirror model over the full one is

.. math:: \\ln B = \\ln \\hat Z_\\text{mirror} - \\ln \\hat Z_\\text{full}, \\qquad
   \\sigma_{\\ln B} = \\sqrt{\\sigma_\\text{mirror}^2 + \\sigma_\\text{full}^2},

each :math:`\\sigma` the merged runs' error (the larger of their own errors combined and their scatter over
:math:`\\sqrt n`, :attr:`~bayestissue.inference.sampling.NestedSample.log_z_err`). Graded by
:func:`~bayestissue.analyses.verdicts.evidence_strength` (Kass & Raftery 1995).

On the joint data set (T1 and T2 as one tissue, :data:`TESTS`) a third model asks whether the two specimens differ
in stiffness alone: the mirror model with one scale :math:`s` multiplying every modulus of T2 (:data:`CANDIDATES`),
reported as :math:`\\ln B` of that model over shared parameters (:data:`FACTORS`).

The 11-parameter posterior is long work (15-23 CPU-minutes per UltraNest run of 400 live points on this machine),
so it runs under ``--full`` only and its record is committed; the default study reads it back. Each model's runs carry
:func:`numbers_hash`, a hash of the code, data and settings their numbers depend on, so a reader can tell whether the
committed numbers still belong to the current code (the report says when they do not), and a ``--full`` rerun
recomputes only the models whose hash changed.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from bayestissue.analyses.box_width import BoxShift, box_shift
from bayestissue.analyses.verdicts import evidence_consistent
from bayestissue.io.results import hash_sources
from bayestissue.mechanics import load_experiment
from bayestissue.paper import MIRROR_TIES
from bayestissue.workflows import load_config
from bayestissue.workflows.problem import build_problem

__all__ = [
    "DATASETS",
    "FACTORS",
    "CANDIDATES",
    "TESTS",
    "SETTINGS",
    "STAGE_SEED",
    "DataChoice",
    "ModelChoiceRecord",
    "ModelEvidence",
    "current_hash",
    "current_hashes",
    "data_files",
    "model_evidence",
    "model_problem",
    "model_settings",
    "numbers_hash",
    "rerun_command",
]

#: The parts of the package the likelihood and the samplers are made of (a change elsewhere, e.g. in the report,
#: leaves the numbers as they are).
SOURCES = ("mechanics", "inference", "workflows", "paper.py", "_validation.py")
#: Modules of :data:`SOURCES` that no nested run imports, left out of the runs' hash: the importance-sampling
#: estimator and its line quadrature, which only the evidence check calls
#: (:func:`~bayestissue.analyses.evidence_check.check_hash` hashes what a check uses with the rest), so that a change
#: of them leaves the nested runs' records current. No other module of :data:`SOURCES` imports them
#: (tests/analyses/test_model_choice.py reads their imports).
NOT_NESTED = ("inference/sampling/importance.py", "inference/sampling/collapsed.py")
#: The stage's seed: data set ``j`` of :data:`DATASETS`, model ``k`` (its place in the data set's :data:`CANDIDATES`:
#: mirror 0, full 1, scale 2) draws its runs' seeds from ``STAGE_SEED + 10 j + k``.
STAGE_SEED = 20261128
#: The data sets the stage can run, in seed order, and the bundled tests each one fits (``joint``: both tests, one
#: material, one noise sd per test).
DATASETS = ("T1", "T2", "joint")
TESTS = {"T1": ("T1",), "T2": ("T2",), "joint": ("T1", "T2")}
#: Each data set's models in seed order, by name -> configuration overrides
#: (:func:`~bayestissue.workflows.load_config`): ``mirror`` ties fibre family 3 to family 2, ``full`` is the paper's
#: 11 parameters, and ``scale`` (joint data set only) is the mirror model with a stiffness scale of T2's specimen (one
#: specimen-level parameter multiplying every modulus of T2, log-uniform on [0.05, 20];
#: :class:`~bayestissue.workflows.forward.SpecimenForward`): the same tissue measured on two specimens of different
#: stiffness.
CANDIDATES = {
    "T1": {"mirror": {"tied": dict(MIRROR_TIES)}, "full": {}},
    "T2": {"mirror": {"tied": dict(MIRROR_TIES)}, "full": {}},
    "joint": {"mirror": {"tied": dict(MIRROR_TIES)}, "full": {},
              "scale": {"tied": dict(MIRROR_TIES), "specimen": ("scale", "T2")}},
}  # fmt: skip
#: The log Bayes factors each data set reports, (numerator, denominator): the mirror model over the paper's, and on
#: the joint data set the T2 stiffness scale over shared parameters.
FACTORS = {"T1": (("mirror", "full"),), "T2": (("mirror", "full"),), "joint": (("mirror", "full"), ("scale", "mirror"))}
#: Nested options per mode and model (:class:`~bayestissue.inference.sampling.NestedOptions`) and where the runs go.
#: ``--full``: 4 runs per model (the verdict's minimum), both models by UltraNest's population slice sampler (2 x d
#: slice steps per new point) with 400 live points, so that the two evidences are estimated the same way. The mirror
#: model ran by nautilus (4 x 200) until 2026-11-29: its runs' own errors (0.04) were 2-4 x below their scatter on T1,
#: and on T2 one run of four lost the peak (log Z 316.98 against 323.66-325.05). The full model ran with 200 live
#: points until 2026-11-29 (2.1-3.0 M calls and 10-20 CPU-minutes per run here): on T2 one run of four lost the
#: peak too (317.57 against 322.54-324.23), and with fewer live points than the mirror model's its evidence was not
#: estimated on the same footing. ``--quick`` is a capped smoke run of
#: the same code (its numbers mean nothing). The default study computes nothing and reads the committed ``--full``
#: record.
SETTINGS = {
    "quick": {
        "scheduler": None,
        "mirror": {"sampler": "ultranest", "n_live": 50, "n_eff": 50, "n_runs": 2, "population": 50,
                   "max_evaluations": 6000},
        "full": {"sampler": "ultranest", "n_live": 50, "n_eff": 50, "n_runs": 2, "population": 50,
                 "max_evaluations": 6000},
        "scale": {"sampler": "ultranest", "n_live": 50, "n_eff": 50, "n_runs": 2, "population": 50,
                  "max_evaluations": 6000},
    },
    "full": {
        "scheduler": "local",
        "mirror": {"sampler": "ultranest", "n_live": 400, "n_eff": 500, "n_runs": 4, "population": 100},
        "full": {"sampler": "ultranest", "n_live": 400, "n_eff": 500, "n_runs": 4, "population": 100},
        "scale": {"sampler": "ultranest", "n_live": 400, "n_eff": 500, "n_runs": 4, "population": 100},
    },
}  # fmt: skip
#: Settings one data set changes under a mode, merged over :data:`SETTINGS` by :func:`model_settings` (so that the
#: other data sets' settings and hashes stay as they were). On T1 + T2 the mirror model's 4 runs with UltraNest's
#: default two slice steps per sampled dimension (16: the runs sample 8, the two noise sds are integrated out)
#: disagreed on the evidence (log Z 909.76-915.43, scatter p = 2e-17) and every run failed the insertion-order test
#: (2026-11-27), whose remedy is more steps per new point: 4 per parameter of each joint model, sds included
#: (mirror 10, full 13, scale 11; tested), i.e. 5.0, 4.7 and 4.9 per sampled dimension (8, 11, 9). At 40 steps the
#: mirror model's four runs still disagree (log Z 912.04-917.19, own errors 0.39-0.55, p = 1.6e-13; the peak lies on
#: gamma2's upper bound, docs/verification.md), so these settings are not yet enough either. UltraNest's mixture
#: directions at 40 steps (2 runs, 2026-11-30) did not help: log Z 910.48 and 912.89, so the directions stay the
#: region's. Nor did 800 live points (population 10, 2026-12-04/05): log Z 911.44-915.65, sd 1.8 against 2.1 at 400.
#: The full and scale models take population 10 (10 new points per step, not 100): on the mirror model that cost 3-4 x
#: fewer calls for the same scatter (2 runs, docs/verification.md), and neither model had runs to keep.
OVERRIDES = {
    ("full", "joint"): {
        "mirror": {"slice_steps": 40},
        "full": {"slice_steps": 52, "population": 10},
        "scale": {"slice_steps": 44, "population": 10},
    },
}


def model_settings(mode: str, data: str, model: str) -> dict:
    """The nested options of ``model`` on ``data`` under ``mode``: :data:`SETTINGS` with :data:`OVERRIDES`."""
    return {**SETTINGS[mode][model], **OVERRIDES.get((mode, data), {}).get(model, {})}


def model_problem(data_dir: Path, data: str, model: str):
    """The calibration problem of ``model`` on ``data``'s bundled tests in ``data_dir`` (:data:`CANDIDATES`,
    :data:`TESTS`): the default box prior, one noise sd per test."""
    experiments = [load_experiment(Path(data_dir) / f"{test}.toml") for test in TESTS[data]]
    return build_problem(experiments, load_config(None, **CANDIDATES[data][model]))


def rerun_command(data: str, models) -> str:
    """The command that (re)runs ``models`` on the data set ``data`` at ``--full`` and keeps the record's others."""
    return f"python studies/full_model.py --full --data {data} --models {' '.join(models)}"


def numbers_hash(data_files, settings: str = "", exclude=NOT_NESTED) -> str:
    """SHA-256 (first 16 hex digits) over the source files of :data:`SOURCES` but ``exclude`` (by default
    :data:`NOT_NESTED`), the bytes of ``data_files`` and the run's ``settings`` text: it changes with anything the
    stage's numbers depend on."""
    h = hash_sources(hashlib.sha256(), SOURCES, exclude=exclude)
    for f in data_files:
        h.update(Path(f).name.encode() + b"\0" + Path(f).read_bytes() + b"\0")
    h.update(settings.encode())
    return h.hexdigest()[:16]


def data_files(data_dir: Path, data: str) -> list[Path]:
    """The experiment files (``.toml`` and ``.csv``) of the tests the data set ``data`` fits, in ``data_dir``: what a
    hash of its numbers reads besides the code and the settings."""
    return [Path(data_dir) / f"{test}.{ext}" for test in TESTS[data] for ext in ("toml", "csv")]


def current_hash(mode: str, data_dir: Path, data: str, model: str) -> str:
    """:func:`numbers_hash` of the current code, the data set ``data`` in ``data_dir``, the seed and ``mode``'s
    settings for ``model`` on ``data`` (:func:`model_settings`; each model its own: a change of one model's
    settings leaves the other's runs current; where the runs went is left out, since a run gives the same numbers
    wherever it ran, docs/cluster.md)."""
    return numbers_hash(data_files(data_dir, data), repr((STAGE_SEED, model, model_settings(mode, data, model))))


def current_hashes(rec: ModelChoiceRecord, data_dir: Path) -> dict[str, dict[str, str]]:
    """Data set -> model -> :func:`current_hash` for every model run in ``rec`` (in ``rec``'s mode)."""
    return {d: {m: current_hash(rec.mode, data_dir, d, m) for m in c.models} for d, c in rec.cases.items()}


@dataclass(frozen=True)
class ModelEvidence:
    """One model's nested runs on one data set.

    Per run: ``log_z`` and its own error, likelihood calls and seconds (of all the sessions that worked on it:
    :func:`~bayestissue.inference.sampling.checkpoints.earlier_cost`; seconds NaN where a session's were not
    recorded), finished (not capped), ``max_log_l`` (its
    largest log-likelihood) and ``peak_reached`` (that within d/2 of ``reference_log_l``, the runs' likelihood
    climbed from the least-squares optima, :mod:`~bayestissue.inference.sampling.peak`: the engine's peak check,
    :attr:`~bayestissue.inference.evidence.NestedReport.short_of_peak`). ``log_z_p``: the p-value of the runs' log Z
    scatter against their own errors (:attr:`~bayestissue.inference.evidence.NestedReport.log_z_p`). ``merged`` is
    the merged runs' (log Z, error). ``quantiles[j]`` the 5 / 50 / 95 % quantiles of sampled parameter
    ``names[j]`` (natural units, exchangeable families folded) and ``quantile_errors[j]`` their Monte Carlo errors
    (:class:`~bayestissue.inference.evidence.NestedReport`); ``unit_quantiles`` the same in box coordinates (0 at
    the lower bound, 1 at the upper, log scale where the prior is log-uniform) and ``run_unit_quantiles[k]`` run
    ``k``'s own. ``verdict`` the engine's verdict line. ``numbers_hash``: :func:`current_hash` of the code, data and
    settings that computed them. ``wall_s``: the stage's wall time for the model, NaN where a run was resumed from
    an earlier session's checkpoint (the wall time of the runs' sessions together is not known). ``box``: the
    evidence under narrowed and widened log boxes
    (:func:`~bayestissue.analyses.box_width.box_shift`; None where the runs' points were not at hand).
    """

    model: str
    numbers_hash: str
    sampler: str
    n_live: int
    slice_steps: int | None
    names: list[str]
    log_z: list[float]
    log_z_err: list[float]
    calls: list[int]
    time_s: list[float]
    finished: list[bool]
    max_log_l: list[float]
    reference_log_l: float
    peak_reached: list[bool]
    log_z_p: float
    merged: tuple[float, float]
    converged: bool
    verdict: str
    rhat_max: float
    quantiles: list[list[float]]
    quantile_errors: list[list[float]]
    unit_quantiles: list[list[float]]
    run_unit_quantiles: list[list[list[float]]]
    wall_s: float
    box: BoxShift | None

    def quantile(self, name: str) -> list[float]:
        """(5 %, 50 %, 95 %) of ``name``."""
        return self.quantiles[self.names.index(name)]

    @property
    def runs_ok(self) -> list[bool]:
        """Per run: finished (not capped) and at the peak."""
        return [f and p for f, p in zip(self.finished, self.peak_reached, strict=True)]

    @property
    def runs_agree(self) -> bool:
        """Whether the runs agree on the evidence (:func:`~bayestissue.analyses.verdicts.evidence_consistent`)."""
        return evidence_consistent(self.log_z_p, self.runs_ok)

    @property
    def wall_text(self) -> str:
        """:attr:`wall_s` as the stage and the report print it ("resumed over sessions" where it is NaN)."""
        return f"{self.wall_s:.0f} s" if np.isfinite(self.wall_s) else "resumed over sessions"


@dataclass(frozen=True)
class DataChoice:
    """The models of one data set (:data:`CANDIDATES`): ``models`` by name, each with the hash of what computed it;
    ``seed`` the first model's (the next model's is one more)."""

    data: str
    seed: int
    models: dict[str, ModelEvidence]

    @property
    def factors(self) -> tuple[tuple[str, str], ...]:
        """The (numerator, denominator) pairs this data set reports (:data:`FACTORS`)."""
        return FACTORS[self.data]

    @property
    def missing(self) -> list[str]:
        """The data set's candidate models (:data:`CANDIDATES`) not run yet, in seed order."""
        return [m for m in CANDIDATES[self.data] if m not in self.models]

    @property
    def factors_run(self) -> tuple[tuple[str, str], ...]:
        """The :attr:`factors` whose two models have both been run (a data set's models may run in separate
        sessions)."""
        return tuple((a, b) for a, b in self.factors if a in self.models and b in self.models)

    def log_bayes(self, a: str = "mirror", b: str = "full") -> tuple[float, float]:
        """:math:`\\ln B` of model ``a`` over model ``b`` and :math:`\\sigma_{\\ln B}` (module docstring)."""
        m, f = self.models[a].merged, self.models[b].merged
        return float(m[0] - f[0]), float(np.hypot(m[1], f[1]))

    def factor_decides(self, a: str = "mirror", b: str = "full") -> bool:
        """Whether :math:`\\ln B` of ``a`` over ``b`` can decide anything: both models' runs agree on the evidence
        (:attr:`ModelEvidence.runs_agree`); otherwise its merged error understates what the runs' scatter shows."""
        return self.models[a].runs_agree and self.models[b].runs_agree

    def log_bayes_moves(self, a: str = "mirror", b: str = "full") -> dict[str, tuple[float, float]] | None:
        """How :math:`\\ln B` of ``a`` over ``b`` moves (value, error) when every log box is narrowed
        (``"narrowed"``) or widened (``"widened_volume"``: the volume terms alone; ``"widened_flat"``: the flat
        estimate; no Monte Carlo error) by :data:`~bayestissue.analyses.box_width.FACTOR`
        (:mod:`~bayestissue.analyses.box_width`); None unless both models carry their :attr:`ModelEvidence.box`."""
        m, f = self.models[a].box, self.models[b].box
        if m is None or f is None:
            return None
        return {
            "narrowed": (m.narrowed[0] - f.narrowed[0], float(np.hypot(m.narrowed[1], f.narrowed[1]))),
            "widened_volume": (m.widened_volume - f.widened_volume, 0.0),
            "widened_flat": (m.widened_flat - f.widened_flat, 0.0),
        }


@dataclass(frozen=True)
class ModelChoiceRecord:
    """The full-model stage's record: one :class:`DataChoice` per data set run (:data:`DATASETS`); ``scheduler``
    and ``n_workers`` where the runs went."""

    SCHEMA: ClassVar[str] = "bayestissue.model_choice"
    VERSION: ClassVar[int] = 4
    mode: str
    scheduler: str
    n_workers: int
    cases: dict[str, DataChoice]


def model_evidence(model: str, sample, report, options, wall_s: float, key: str) -> ModelEvidence:
    """The record of one model's :class:`~bayestissue.inference.sampling.NestedSample` and its
    :class:`~bayestissue.inference.evidence.NestedReport` (assessed against a reference log-likelihood, the stage's
    climbed from the least-squares optima: without it the peak check cannot run); ``key`` its :func:`current_hash`."""
    if report.reference_log_l is None:
        raise ValueError("the report has no reference log-likelihood: assess_nested(..., reference_log_l=...)")
    runs = sample.runs
    to_unit = sample.problem.parameters.to_unit
    q = report.quantiles()
    return ModelEvidence(
        model=model,
        numbers_hash=key,
        sampler=options.sampler,
        n_live=options.n_live,
        slice_steps=options.slice_steps,
        names=list(sample.names),
        log_z=[r.log_z for r in runs],
        log_z_err=[r.log_z_err for r in runs],
        calls=[r.n_like for r in runs],
        time_s=[r.time_s for r in runs],
        finished=[bool(r.finished) for r in runs],
        max_log_l=[float(v) for v in report.max_log_l],
        reference_log_l=float(report.reference_log_l),
        peak_reached=[not s for s in np.asarray(report.short_of_peak, dtype=bool).tolist()],
        log_z_p=float(report.log_z_p),
        merged=(sample.log_z, sample.log_z_err),
        converged=report.converged,
        verdict=report.verdict(),
        rhat_max=float(np.nanmax(report.rhat)) if np.any(np.isfinite(report.rhat)) else float("nan"),
        quantiles=q.tolist(),
        quantile_errors=report.quantile_errors().tolist(),
        unit_quantiles=to_unit(q.T).T.tolist(),
        run_unit_quantiles=[to_unit(qk.T).T.tolist() for qk in report.q_runs],
        wall_s=float("nan") if any(r.n_like_resumed for r in runs) else float(wall_s),
        box=box_shift(runs, sample.problem.parameters.sampled),
    )

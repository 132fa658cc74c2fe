"""The nautilus run behind an evidence check (:mod:`~bayestissue.analyses.evidence_check`): its draws are what the
importance proposal is fitted to. It is cached under a hash of what it depends on and resumes from its checkpoint
when a stage is killed; its cache key (:func:`~bayestissue.analyses.evidence_check.proposal_hash`) leaves the
importance sampler out, so that a rerun of the checks after a change of the importance sampler alone reruns only the
importance sampling."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayestissue.inference import NestedOptions, sample_nested
from bayestissue.inference.sampling.nested import RunPhases

__all__ = ["ProposalRun", "proposal_run"]


@dataclass(frozen=True)
class ProposalRun:
    """The nautilus run a check's proposal is fitted to: its parameter sets ``points`` ``(n, n_parameters)`` and
    their ``weights`` (summing to one), its own ``log_z``, likelihood ``calls`` and seconds ``time_s``, and
    ``cached``: read back from an earlier stage's cache rather than run."""

    points: np.ndarray
    weights: np.ndarray
    log_z: float
    calls: int
    time_s: float
    cached: bool = False


def proposal_run(problem, opts: NestedOptions, seed: int, path: Path | None, progress=None) -> ProposalRun:
    """The nautilus run of ``problem`` (``opts``, ``seed``) whose draws the proposal is fitted to, read from ``path``
    (an ``.npz`` written by an earlier call under the same
    :func:`~bayestissue.analyses.evidence_check.proposal_hash`) when it exists, else run and
    written there (when ``path`` is given; atomically, so that a killed stage leaves no partial file).

    While it runs (T1's full model: over an hour) nautilus checkpoints into the folder ``path`` names with the suffix
    ``.nautilus`` after every ``opts.report_every`` likelihood calls, and ``progress(line)`` says how far it is: a
    stage killed during the run resumes it from there (the folder's name holds the hash, so that only a run of the
    same code, data, seed and settings is resumed; a resumed run gives the draws of an uninterrupted one, measured
    on T1's mirror model at 100 live points, tests/analyses/test_evidence_check.py). The folder is removed once the
    draws are written."""
    if path is not None and Path(path).is_file():
        with np.load(path) as f:
            return ProposalRun(f["points"], f["weights"], float(f["log_z"]), int(f["calls"]), float(f["time_s"]),
                               cached=True)  # fmt: skip
    checkpoint = None if path is None else Path(path).with_suffix(".nautilus")
    resume = checkpoint is not None and checkpoint.is_dir()
    if resume and progress is not None:
        progress(f"nautilus resumes from {checkpoint}")

    phases = RunPhases(opts.n_eff)

    def report(k, calls, n_eff, explored, log_z):
        phases.update(k, calls, n_eff, explored)
        progress(f"nautilus {phases.evaluations} calls, {phases.text()}, log Z {log_z:.2f}")

    run = sample_nested(problem, options=opts, rng=seed, checkpoint=checkpoint, resume=resume,
                        progress=None if progress is None else report).runs[0]  # fmt: skip
    found = ProposalRun(np.asarray(run.points), np.asarray(run.weights), float(run.log_z), int(run.n_like),
                        float(run.time_s))  # fmt: skip
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        part = Path(path).with_suffix(".part.npz")
        np.savez(part, points=found.points, weights=found.weights, log_z=found.log_z, calls=found.calls,
                 time_s=found.time_s)  # fmt: skip
        part.replace(path)
        shutil.rmtree(checkpoint, ignore_errors=True)
    return found

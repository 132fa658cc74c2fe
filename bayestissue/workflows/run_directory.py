"""A calibration's output directory as a unit: one run at a time, a manifest of what it ran on, checked resumes.

Layout of a run directory (``bayestissue fit ... --out DIR``)::

    DIR/.lock            held (``flock``) by the run and its forked workers; holds the pid of the run
    DIR/manifest.json    inputs (hashes of every file read, the resolved configuration, the package's source
                         hash, the seed) and the status: running, finished or failed
    DIR/checkpoints/     the sampler's HDF5 checkpoints
    DIR/posterior.nc ... the results

:func:`open_run_directory` (a context manager) takes the lock, then:

* a fresh run refuses a directory that is not empty (``overwrite=True`` removes the previous run's checkpoints
  and manifest first; other files are replaced as the new results are written);
* a resume refuses a directory without a manifest, any difference between the stored manifest and the new one
  except in :data:`RESUMABLE` (e.g. a longer ``max_steps``), and an unreadable checkpoint; it reports how far each
  run had got.

The lock is an advisory ``flock`` on ``.lock``: the kernel releases it when the last process holding the file
descriptor ends, however it ends, so a killed run never leaves a lock behind; the pid in the file then tells the
next run which run was interrupted (the manifest still says ``running``). Workers are forked with the descriptor
and die with their parent (:mod:`bayestissue.inference.sampling.processes`), so the lock is free once the run is
gone. ``flock`` is local to one machine (not reliable on some network file systems; docs/reliability.md).
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import json
import os
import shutil
import socket
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from bayestissue import __version__
from bayestissue._validation import ValidationError
from bayestissue.inference.sampling.checkpoints import stored_progress
from bayestissue.io.paths import check_output_dir
from bayestissue.io.results import file_sha256, package_sha256

__all__ = ["RESUMABLE", "RunDirectory", "run_manifest", "open_run_directory", "manifest_differences", "run_status"]

LOCK, MANIFEST, CHECKPOINTS = ".lock", "manifest.json", "checkpoints"

#: Configuration entries a resume may change: they decide how long the runs go on, how the results are stored or
#: whether a finished sample is cross-checked, not what is sampled.
RESUMABLE = frozenset(
    {
        "sampler.max_steps",
        "sampler.min_steps",
        "sampler.n_processes",
        "sampler.scheduler",
        "cross_check",
        "nested.max_evaluations",
        "nested.report_every",
        "nested.n_processes",
        "nested.scheduler",
        "max_draws",
        "n_predictive",
    }
)


def _flat(d: Mapping, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, Mapping) and k in ("sampler", "nested"):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def run_manifest(config, experiments: Sequence, *, config_path: str | Path | None = None) -> dict:
    """The manifest of a calibration: what it runs on (every file read, hashed), with what configuration, code
    and seed. Two runs with equal manifests compute the same posterior."""
    resolved = json.loads(json.dumps(dataclasses.asdict(config), default=str, sort_keys=True))
    inputs = []
    for e in experiments:
        entry = {"experiment": e.name}
        for role, p in (("file", e.source), ("data_file", e.data_file)):
            if p is not None and Path(p).is_file():
                entry[role] = str(p)
                entry[f"{role}_sha256"] = file_sha256(p)
        inputs.append(entry)
    return {
        "format": 1,
        "bayestissue_version": __version__,
        "package_sha256": package_sha256(),
        "seed": int(config.seed),
        "engine": config.engine,
        "config_file": None if config_path is None else str(config_path),
        "config_file_sha256": None if config_path is None else file_sha256(config_path),
        "config": resolved,
        "inputs": inputs,
    }


def manifest_differences(old: Mapping, new: Mapping) -> list[str]:
    """What differs between a stored manifest and a new one, as short phrases (empty: the same run)."""
    diffs = []
    if old.get("package_sha256") != new.get("package_sha256"):
        diffs.append(
            f"the code (bayestissue {old.get('bayestissue_version')} source {str(old.get('package_sha256'))[:12]} "
            f"-> {new.get('bayestissue_version')} source {str(new.get('package_sha256'))[:12]})"
        )
    a, b = old.get("inputs", []), new.get("inputs", [])
    if [x.get("experiment") for x in a] != [x.get("experiment") for x in b]:
        diffs.append(f"experiments {[x.get('experiment') for x in a]} -> {[x.get('experiment') for x in b]}")
    else:
        for x, y in zip(a, b, strict=True):
            for role in ("file", "data_file"):
                if x.get(f"{role}_sha256") != y.get(f"{role}_sha256"):
                    diffs.append(
                        f"{x['experiment']}'s {role.replace('_', ' ')} {x.get(role)} -> {y.get(role)} (content changed)"
                    )
    ra, rb = old.get("replicates") or {}, new.get("replicates") or {}
    if any(ra.get(k) != rb.get(k) for k in ("file_sha256", "n_replicates")):
        diffs.append(f"the stereology replicates {ra or None} -> {rb or None}")
    fa, fb = _flat(old.get("config", {})), _flat(new.get("config", {}))
    for key in sorted(set(fa) | set(fb)):
        if key not in RESUMABLE and fa.get(key) != fb.get(key):
            diffs.append(f"{key} {fa.get(key)!r} -> {fb.get(key)!r}")
    return diffs


@dataclass
class RunDirectory:
    """An open run directory: its manifest, and what the opening found (for the caller to print)."""

    path: Path
    manifest: dict
    resumed: list[int] = field(default_factory=list)
    unit: str = ""
    notes: list[str] = field(default_factory=list)

    @property
    def checkpoints(self) -> Path:
        return self.path / CHECKPOINTS

    def set_status(self, status: str, **extra) -> None:
        """Record the run's status in the manifest (written to a temporary file, then renamed: never half)."""
        self.manifest.update(status=status, **extra)
        tmp = self.path / f".{MANIFEST}.tmp"
        tmp.write_text(json.dumps(self.manifest, indent=2) + "\n")
        os.replace(tmp, self.path / MANIFEST)


def _lock(path: Path) -> tuple[int, str | None]:
    """Take the directory's lock; returns the descriptor and the previous holder's record (if any)."""
    import fcntl

    fd = os.open(path / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "unknown pid"
        os.close(fd)
        raise ValidationError(
            "--out", str(path), "a run directory no other run is using", f"in use by {holder}; wait or choose another"
        ) from None
    previous = os.pread(fd, 200, 0).decode(errors="replace").strip() or None
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}\n".encode(), 0)
    return fd, previous


def _read_manifest(path: Path) -> dict | None:
    p = path / MANIFEST
    if not p.exists():
        return None
    try:
        return json.loads(p.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise ValidationError(
            str(p), "unreadable", "the run's manifest (JSON)", "start over with --overwrite"
        ) from None


def run_status(path: str | Path) -> str | None:
    """The status its manifest records for the run directory ``path`` (running, finished, failed), or None without
    one."""
    stored = _read_manifest(Path(path)) if Path(path).is_dir() else None
    return None if stored is None else stored.get("status")


def _occupied(path: Path) -> list[str]:
    return sorted(p.name for p in path.iterdir() if p.name not in (LOCK, f".{MANIFEST}.tmp"))


@contextlib.contextmanager
def open_run_directory(
    path: str | Path,
    manifest: dict,
    *,
    resume: bool = False,
    overwrite: bool = False,
) -> Iterator[RunDirectory]:
    """Open ``path`` for one run described by ``manifest`` (see the module docstring); the status in the manifest
    is ``finished`` after a normal exit and ``failed`` after an exception; the lock is released in either case.

    Raises
    ------
    ValidationError
        ``--out`` an existing file, busy, not empty (fresh run without ``overwrite``), nothing to resume, a
        different run (naming what changed), or an unreadable manifest or checkpoint.
    """
    path = check_output_dir("--out", path)
    created = not path.exists()
    if resume and created:
        raise ValidationError("--resume", str(path), "an existing run directory", "nothing to resume: check --out")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValidationError("--out", str(path), "a directory that can be created", exc.strerror) from None
    fd, previous = _lock(path)
    try:
        run = RunDirectory(path, dict(manifest))
        stored = _read_manifest(path)
        if stored is not None and stored.get("status") == "running" and previous:
            run.notes.append(f"the previous run in {path} ({previous}) was interrupted before it finished")
        try:
            if resume:
                _check_resume(run, stored)
            else:
                _check_fresh(run, overwrite)
        except ValidationError:
            if created:
                shutil.rmtree(path, ignore_errors=True)
            raise
        run.set_status(
            "running",
            pid=os.getpid(),
            started_utc=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            resumed=run.resumed,
        )
        try:
            yield run
        except ValidationError:
            if _occupied(path) == [MANIFEST] and not resume:  # refused input: leave nothing behind
                (path / MANIFEST).unlink()
                if created:
                    shutil.rmtree(path, ignore_errors=True)
            else:
                run.set_status("failed", error="bad input")
            raise
        except BaseException as exc:
            run.set_status("failed", error=f"{type(exc).__name__}: {exc}"[:300])
            raise
        run.set_status("finished", finished_utc=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"))
    finally:
        os.close(fd)


def _n_runs(manifest: Mapping) -> int:
    """The number of independent runs the manifest's configuration asks for (nested runs or emcee ensembles)."""
    engine, config = manifest["engine"], manifest.get("config", {})
    return config["nested"]["n_runs"] if engine == "nested" else config["sampler"]["n_ensembles"]


def _check_resume(run: RunDirectory, stored: dict | None) -> None:
    if stored is None:
        raise ValidationError(
            "--resume", str(run.path), f"a run directory with a {MANIFEST}", "nothing to resume: run without --resume"
        )
    diffs = manifest_differences(stored, run.manifest)
    if diffs:
        raise ValidationError(
            "--resume", str(run.path), "the same inputs, configuration and code as the stored run", "; ".join(diffs)
        )
    if run.checkpoints.exists() and not run.checkpoints.is_dir():
        raise ValidationError("--resume", str(run.checkpoints), f"a folder of checkpoints ({CHECKPOINTS}/ is a file)")
    run.resumed, run.unit = stored_progress(run.checkpoints, run.manifest["engine"], _n_runs(run.manifest))


def _check_fresh(run: RunDirectory, overwrite: bool) -> None:
    there = _occupied(run.path)
    if not there:
        return
    if not overwrite:
        shown = ", ".join(there[:4]) + (", ..." if len(there) > 4 else "")
        raise ValidationError(
            "--out",
            str(run.path),
            "an empty or new directory",
            f"it holds {shown}: --resume continues that run, --overwrite replaces it",
        )
    shutil.rmtree(run.checkpoints, ignore_errors=True)
    for sub in run.path.glob("replicate_*/"):  # a cut posterior's runs (bayestissue.workflows.cut)
        shutil.rmtree(sub, ignore_errors=True)
    (run.path / MANIFEST).unlink(missing_ok=True)
    run.notes.append(f"--overwrite: removed the previous run's checkpoints and manifest in {run.path}")

"""Calibration configuration (TOML) and results (arviz InferenceData in NetCDF) with provenance.

Every results file carries, as global attributes: the package version, the seed, SHA-256 hashes of
the configuration file and of every data file, the creation time (UTC) and free-form entries given
by the caller.

The configuration file's schema is validated in :mod:`bayestissue.workflows.config`.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
from collections.abc import Iterable, Mapping
from pathlib import Path

from bayestissue import __version__
from bayestissue.io.toml_files import read_toml

__all__ = [
    "file_sha256",
    "package_sha256",
    "RUN_SOURCES",
    "source_files",
    "hash_sources",
    "read_config",
    "provenance",
    "write_inference_data",
    "read_inference_data",
]


def file_sha256(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"file {str(path)!r} does not exist")
    return hashlib.sha256(path.read_bytes()).hexdigest()


def source_files(parts: Iterable[str] | None = None, package: str | Path | None = None,
                 exclude: Iterable[str] = ()) -> list[Path]:  # fmt: skip
    """The package's source files: under each of ``parts`` (sub-packages or modules, relative to the package, in
    the given order; each part's files sorted), or every one (sorted) when ``parts`` is None; without the files
    ``exclude`` names (paths relative to the package, ``/``-separated)."""
    package = Path(__file__).resolve().parents[1] if package is None else Path(package)
    if parts is None:
        files = sorted(package.rglob("*.py"))
    else:
        roots = [package / part for part in parts]
        files = [f for root in roots for f in (sorted(root.rglob("*.py")) if root.is_dir() else [root])]
    left_out = set(exclude)
    return [f for f in files if f.relative_to(package).as_posix() not in left_out]


#: The parts of the package a calibration's numbers come from: the mechanics, the samplers, the workflow that builds
#: the problem, the readers of its inputs and the checks on them (:func:`package_sha256`'s default). A run
#: directory's manifest hashes these, so that a change of the report, the figures or the command line leaves a run
#: resumable, and a change of anything its numbers depend on does not.
RUN_SOURCES = ("mechanics", "inference", "workflows", "io", "stereology", "paper.py", "parallel.py", "_schema.py",
               "_validation.py")  # fmt: skip


def package_sha256(package: str | Path | None = None, parts: Iterable[str] | None = RUN_SOURCES) -> str:
    """Hex SHA-256 over source files of the package (relative path and bytes; :func:`source_files` of ``parts``,
    by default :data:`RUN_SOURCES`; ``parts=None``: every source file): changes with any change of that code, and
    only then."""
    return hash_sources(hashlib.sha256(), parts, package).hexdigest()


def hash_sources(h, parts: Iterable[str] | None = None, package: str | Path | None = None,
                 exclude: Iterable[str] = ()):  # fmt: skip
    """Feed each of :func:`source_files` (``parts``, every file when None, without ``exclude``) to the hash object
    ``h`` as its path relative to the package, a NUL, its bytes and a NUL; returns ``h`` (to go on with other
    inputs)."""
    package = Path(__file__).resolve().parents[1] if package is None else Path(package)
    for f in source_files(parts, package, exclude):
        h.update(f.relative_to(package).as_posix().encode() + b"\0" + f.read_bytes() + b"\0")
    return h


def read_config(path: str | Path | None) -> dict:
    """Read a calibration configuration (TOML) as a plain mapping; ``None`` gives an empty one.

    The schema is checked by :func:`bayestissue.workflows.config.config_from_mapping`.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValidationError
        If it is not valid TOML.
    """
    if path is None:
        return {}
    return read_toml(Path(path), "configuration")


def provenance(
    *,
    seed: int | None,
    config_path: str | Path | None = None,
    data_paths: Iterable[str | Path] = (),
    extra: Mapping | None = None,
) -> dict:
    """Provenance attributes: version, seed, UTC time, config and data file hashes (NetCDF-safe
    values)."""
    attrs = {
        "bayestissue_version": __version__,
        "seed": -1 if seed is None else int(seed),
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "config_file": "" if config_path is None else str(config_path),
        "config_sha256": "" if config_path is None else file_sha256(config_path),
    }
    for p in data_paths:
        attrs[f"data_sha256:{Path(p).name}"] = file_sha256(p)
    for k, v in (extra or {}).items():
        attrs[str(k)] = v if isinstance(v, int | float | str) else str(v)
    return attrs


def write_inference_data(idata, path: str | Path, *, attrs: Mapping | None = None) -> Path:
    """Write an arviz ``InferenceData`` to NetCDF (h5netcdf), adding ``attrs`` to every group."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    for group in idata.groups():
        getattr(idata, group).attrs.update(dict(attrs or {}))
    idata.to_netcdf(str(path), engine="h5netcdf")
    return path


def read_inference_data(path: str | Path):
    """Read an ``InferenceData`` written by :func:`write_inference_data`."""
    import warnings

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"results file {str(path)!r} does not exist")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import arviz as az
    return az.from_netcdf(str(path), engine="h5netcdf")

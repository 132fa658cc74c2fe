"""Calibration configuration (TOML) and results (arviz InferenceData in NetCDF) with provenance.

Every results file carries, as global attributes: the package version, the seed, SHA-256 hashes of
the configuration file and of every data file, the creation time (UTC) and free-form entries given
by the caller.

Configuration file (all sections and keys optional)::

    [parameters]
    prior = "default"                 # or "uniform" (uniform on the box for every parameter)
    fixed = { ginf1 = 125.0 }         # name -> value, or a list of names held at their initial
    value
    sampled = ["mu", "kappa"]         # sample only these (the rest are fixed at their initial
    value)
    bounds = { mu = [0.001, 1000] }
    priors = { mu = "uniform" }
    initial = { mu = 10.0 }
    tied = { ginf3 = "ginf2" }        # takes the other parameter's value (one law for two families)

    [likelihood]
    noise = "gaussian"                # "gaussian", "ar1", "student_t"
    sd = 0.02                         # known sd (mm); omit to sample it
    nu = 4.0                          # Student-t degrees of freedom

    [warmstart]
    n_starts = 8

    [sampler]
    seed = 20261121
    n_ensembles = 4
    moves = "de_snooker"              # or "mixture": fitted Student-t independence proposals + DE
    coordinates = "box"               # or "creep" (creep tests, tied families 2/3) or "ramp" (force ramps)
    max_steps = 20000
"""

from __future__ import annotations

import datetime as _dt
import hashlib
from collections.abc import Iterable, Mapping
from pathlib import Path

from bayestissue import __version__
from bayestissue._validation import ValidationError
from bayestissue.io.toml_files import read_toml

__all__ = [
    "CONFIG_SECTIONS",
    "file_sha256",
    "read_config",
    "provenance",
    "write_inference_data",
    "read_inference_data",
]

#: Sections a calibration configuration file may contain.
CONFIG_SECTIONS = ("parameters", "likelihood", "warmstart", "sampler", "output")


def file_sha256(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"file {str(path)!r} does not exist")
    return hashlib.sha256(path.read_bytes()).hexdigest()


def read_config(path: str | Path | None) -> dict:
    """Read a calibration configuration (TOML); ``None`` gives an empty configuration.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValidationError
        If it is not valid TOML or has an unknown section.
    """
    if path is None:
        return {}
    path = Path(path)
    cfg = read_toml(path, "configuration")
    unknown = sorted(set(cfg) - set(CONFIG_SECTIONS))
    if unknown:
        raise ValidationError(
            f"configuration {path.name} sections",
            unknown,
            f"sections among {list(CONFIG_SECTIONS)}",
        )
    return cfg


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

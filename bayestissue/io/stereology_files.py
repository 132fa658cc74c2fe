"""Stereology files: point counts, line systems (with a TOML sidecar) and the replicate table.

All tables are CSV with ``# key: value`` comment lines (:mod:`bayestissue.io.tables`); synthetic
files say so in a ``# synthetic:`` line.

Point counts (``data/stereology_counts.csv``)
    One row per sampled section. ``section`` (position in the series, 0-based), one
    ``<component>_points`` column per component (points of the grid hitting it; e.g. ``smc_points,
    ecm_points, other_points``), optional ``block`` (label of an independent unit: tissue block or
    animal). Comment keys: ``excluded`` (comma-separated components outside the reference space,
    default ``other`` and ``cavity``), ``grid_spacing_um`` (optional), ``n_series`` (sections in the
    whole series), ``period``, ``nugget_shape_factor`` (profile b / sqrt(a)) and
    ``nugget_profiles_per_section`` (for the point-counting noise of the CE).

Line system (``data/stereology_lines.csv`` + ``data/stereology_lines.toml``)
    One row per straight segment: ``cell`` (id of the traced cell), ``x0_um, y0_um, z0_um, x1_um,
    y1_um, z1_um`` (end points, body frame: x loading/longitudinal, y top-down, z the rest). A
    polyline is several rows with the same ``cell``. The sidecar (same stem, ``.toml``) gives
    ``volume_um3`` (probed volume), or ``extent_x_um``, ``extent_y_um``, ``n_sections`` and
    ``section_thickness_um`` from which it is computed.

Replicate table (``data/stereology_replicates.csv``): the contract with the mechanics
    One row per bootstrap replicate, columns in this order:

    - ``replicate``: 1 ... B.
    - ``phi_smc``, ``phi_ecm``: volume fractions of SMC and ECM in the reference space (tissue
      without haemocoelic cavities), drawn jointly, each in [0, 1], ``phi_smc + phi_ecm = 1``.
    - ``phi_matrix``: matrix volume fraction of the mechanics, equal to ``phi_ecm``.
    - ``phi_fibre1``, ``phi_fibre2``, ``phi_fibre3``: the SMC fraction split between the fibre
      families, summing to ``phi_smc``; the split method is in the ``# split:`` comment line
      (``paper``: equal thirds; ``length``: the families' length shares).
    - ``v1_x, v1_y, v1_z, v2_x, ..., v3_z``: unit fibre directions; family k is matched to the
      paper's v_k (v1 = [0, 1, 0] along y; v2 = [0.9369, 0.3420, 0], x tilted toward +y; v3 =
      [0.9369, -0.3420, 0], x tilted toward -y) by an optimal axial assignment, with the sign chosen
      so that v_k . paper_v_k >= 0.

    - optional ``disp_fibre1``, ``disp_fibre2``, ``disp_fibre3``: each family's GOH dispersion
      kappa = (1 - A(k))/2 of its Watson concentration k (Gasser, Ogden & Holzapfel 2006;
      :func:`bayestissue.stereology.axial.watson_goh_dispersion`), in [0, 1/3]; written when the
      directions come from a Watson mixture. A fibre law with a dispersion parameter takes it from here
      (:func:`bayestissue.analyses.propagate.replicate_dispersion`).

    The mechanics takes ``phi_matrix``, ``phi_fibre1..3``, ``v1..v3`` and, where present,
    ``disp_fibre1..3`` (:func:`read_replicates`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.io.tables import read_table, write_table
from bayestissue.io.toml_files import read_toml

__all__ = [
    "REPLICATE_COLUMNS",
    "DISPERSION_COLUMNS",
    "read_point_counts",
    "write_point_counts",
    "read_line_system",
    "write_line_system",
    "sidecar_path",
    "read_replicates",
    "write_replicates",
]

REPLICATE_COLUMNS = (
    "replicate",
    "phi_smc",
    "phi_ecm",
    "phi_matrix",
    "phi_fibre1",
    "phi_fibre2",
    "phi_fibre3",
    *(f"v{k}_{c}" for k in (1, 2, 3) for c in "xyz"),
)
#: Optional columns of the replicate table: the families' GOH dispersions (module docstring).
DISPERSION_COLUMNS = ("disp_fibre1", "disp_fibre2", "disp_fibre3")
#: The largest point count of one component on one section: a grid of 10^7 points (a 3162 x 3162 grid) is far
#: beyond any counted section; larger values are typing or export errors (1e300 would otherwise give V_V = 1).
MAX_POINTS = 1e7
_SEGMENT_COLUMNS = ("cell", "x0_um", "y0_um", "z0_um", "x1_um", "y1_um", "z1_um")


def read_point_counts(path: str | Path) -> dict:
    """Read a point-count table.

    Returns
    -------
    dict with ``section`` (n,) int, ``counts`` (n, K) float, ``components`` (tuple of K names, from
    the ``<name>_points`` columns), ``excluded`` (tuple), ``grid_spacing_um`` (float or None),
    ``block`` ((n,) or None) and ``meta`` (the comment lines).
    """
    cols, meta = read_table(path, required=("section",), numeric=lambda c: c == "section" or c.endswith("_points"))
    names = [c for c in cols if c.endswith("_points")]
    if not names:
        raise ValidationError(
            f"{Path(path).name} columns",
            list(cols),
            "one '<component>_points' column per component",
        )
    name = Path(path).name
    section = cols["section"]
    bad = np.flatnonzero((section != np.round(section)) | (section < 0))
    if bad.size:
        raise ValidationError(f"{name} data row {bad[0] + 1} column section", section[bad[0]], "a section number >= 0")
    seen, first = np.unique(section, return_index=True)
    if seen.size < section.size:
        dup = np.setdiff1d(np.arange(section.size), first)[0]
        raise ValidationError(f"{name} data row {dup + 1} column section", section[dup], "each section once")
    counts = np.stack([cols[c] for c in names], axis=1)
    bad = np.argwhere((counts != np.round(counts)) | (counts < 0) | (counts > MAX_POINTS))
    if bad.size:
        i, j = bad[0]
        raise ValidationError(
            f"{name} data row {i + 1} column {names[j]}",
            counts[i, j],
            f"a whole number of points in [0, {MAX_POINTS:g}]",
        )
    empty = np.flatnonzero(counts.sum(axis=0) == 0)
    if empty.size:  # no point hit it in any section: every ratio and variance of it is 0/0
        hint = "leave out the column of a component that is not there"
        raise ValidationError(f"{name} column {names[empty[0]]}", "0 points in every section", "a point hit", hint)
    components = tuple(c[: -len("_points")] for c in names)
    if "excluded" in meta:
        excluded = tuple(s.strip() for s in meta["excluded"].split(",") if s.strip())
    else:
        excluded = tuple(e for e in ("other", "cavity") if e in components)
    gs = meta.get("grid_spacing_um")
    sf = meta.get("nugget_shape_factor")
    pp = meta.get("nugget_profiles_per_section")
    return {
        "nugget_shape_factor": float(sf) if sf else None,
        "nugget_profiles_per_section": float(pp) if pp else None,
        "section": cols["section"].astype(int),
        "counts": counts,
        "components": components,
        "excluded": excluded,
        "grid_spacing_um": float(gs) if gs else None,
        "block": cols.get("block"),
        "meta": meta,
    }


def write_point_counts(path: str | Path, section, counts, components, *, block=None, meta: dict | None = None) -> Path:
    """Write a point-count table (columns ``section``, ``<component>_points``..., optional
    ``block``)."""
    counts = np.asarray(counts)
    cols = {"section": np.asarray(section, dtype=int)}
    for j, c in enumerate(components):
        cols[f"{c}_points"] = counts[:, j].astype(int)
    if block is not None:
        cols["block"] = np.asarray(block)
    return write_table(path, cols, meta=meta)


def sidecar_path(path: str | Path) -> Path:
    """The TOML sidecar of a line-system CSV: same folder and stem, suffix ``.toml``."""
    return Path(path).with_suffix(".toml")


def read_line_system(path: str | Path) -> dict:
    """Read a line-system table and its sidecar.

    Returns
    -------
    dict with ``start`` (n, 3), ``end`` (n, 3) in um, ``cell`` (n,), ``volume_um3`` (float or None),
    ``sidecar`` (dict) and ``meta`` (CSV comment lines).
    """
    cols, meta = read_table(path, required=_SEGMENT_COLUMNS, numeric=_SEGMENT_COLUMNS[1:])
    side = {}
    sp = sidecar_path(path)
    if sp.is_file():
        side = read_toml(sp, "line-system sidecar")
    volume = side.get("volume_um3", meta.get("volume_um3"))
    if volume is None and all(k in side for k in ("extent_x_um", "extent_y_um", "n_sections", "section_thickness_um")):
        volume = side["extent_x_um"] * side["extent_y_um"] * side["n_sections"] * side["section_thickness_um"]
    cell = cols["cell"]
    if cell.dtype.kind == "f" and np.all(cell == np.round(cell)):
        cell = cell.astype(int)
    return {
        "start": np.stack([cols["x0_um"], cols["y0_um"], cols["z0_um"]], axis=1),
        "end": np.stack([cols["x1_um"], cols["y1_um"], cols["z1_um"]], axis=1),
        "cell": cell,
        "volume_um3": None if volume is None else float(volume),
        "sidecar": side,
        "meta": meta,
    }


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float | np.integer | np.floating):
        return repr(float(v)) if isinstance(v, float | np.floating) else str(int(v))
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return '"' + str(v).replace("\\", "\\\\").replace('"', '\\"') + '"'


def write_line_system(
    path: str | Path, start, end, cell, *, sidecar: dict | None = None, meta: dict | None = None
) -> Path:
    """Write a line-system table and (if ``sidecar`` is given) its flat TOML sidecar."""
    start = np.asarray(start, dtype=float)
    end = np.asarray(end, dtype=float)
    cols = {"cell": np.asarray(cell)}
    for j, c in enumerate("xyz"):
        cols[f"{c}0_um"] = start[:, j]
    for j, c in enumerate("xyz"):
        cols[f"{c}1_um"] = end[:, j]
    p = write_table(path, cols, meta=meta, fmt="%.6f")
    if sidecar is not None:
        lines = [f"{k} = {_toml_value(v)}" for k, v in sidecar.items()]
        sidecar_path(path).write_text("\n".join(lines) + "\n")
    return p


def write_replicates(path: str | Path, columns: dict, *, meta: dict | None = None) -> Path:
    """Write the replicate table (columns :data:`REPLICATE_COLUMNS` in order, then :data:`DISPERSION_COLUMNS` if
    ``columns`` has them)."""
    missing = [c for c in REPLICATE_COLUMNS if c not in columns]
    if missing:
        raise ValidationError("replicate columns", sorted(columns), f"all of {list(REPLICATE_COLUMNS)}")
    names = REPLICATE_COLUMNS + (DISPERSION_COLUMNS if DISPERSION_COLUMNS[0] in columns else ())
    return write_table(path, {c: columns[c] for c in names}, meta=meta)


def read_replicates(path: str | Path) -> dict:
    """Read the replicate table for the mechanics.

    Returns
    -------
    dict with ``phi_matrix`` (n,), ``phi_fibres`` (n, 3), ``directions`` (n, 3, 3) (row k = unit
    v_k), ``phi_smc`` (n,), ``phi_ecm`` (n,), ``dispersion`` ((n, 3) from ``disp_fibre1..3``, or None
    without them), ``split`` (str) and ``meta``.

    Raises
    ------
    ValidationError for missing columns, fractions outside [0, 1], non-unit directions (|v| - 1 >
    1e-6), some but not all dispersion columns, or a dispersion outside [0, 1/3].
    """
    cols, meta = read_table(path, required=REPLICATE_COLUMNS, numeric=True)
    phi_f = np.stack([cols[f"phi_fibre{k}"] for k in (1, 2, 3)], axis=1)
    D = np.stack([np.stack([cols[f"v{k}_{c}"] for c in "xyz"], axis=1) for k in (1, 2, 3)], axis=1)
    for name, a in (("phi_matrix", cols["phi_matrix"]), ("phi_fibre", phi_f)):
        if np.any(~np.isfinite(a)) or np.any(a < 0) or np.any(a > 1):
            raise ValidationError(name, "a value outside [0, 1]", "volume fractions in [0, 1]")
    norm = np.linalg.norm(D, axis=2)
    if np.any(np.abs(norm - 1) > 1e-6):
        i, k = np.argwhere(np.abs(norm - 1) > 1e-6)[0]
        raise ValidationError(f"v{k + 1} of replicate row {i + 1}", D[i, k].tolist(), "a unit vector")
    disp = None
    have = [c for c in DISPERSION_COLUMNS if c in cols]
    if have and len(have) < 3:
        raise ValidationError(f"{path}: dispersion columns", have, f"all of {list(DISPERSION_COLUMNS)} or none")
    if have:
        disp = np.stack([cols[c] for c in DISPERSION_COLUMNS], axis=1)
        bad = np.argwhere(~(np.isfinite(disp) & (disp >= 0) & (disp <= 1.0 / 3.0)))
        if bad.size:
            i, k = bad[0]
            raise ValidationError(f"{path}: disp_fibre{k + 1} of replicate row {i + 1}", float(disp[i, k]),
                                  "a GOH dispersion in [0, 1/3]")  # fmt: skip
    return {
        "phi_matrix": cols["phi_matrix"],
        "phi_fibres": phi_f,
        "directions": D,
        "phi_smc": cols["phi_smc"],
        "phi_ecm": cols["phi_ecm"],
        "dispersion": disp,
        "split": meta.get("split", "unknown"),
        "meta": meta,
    }

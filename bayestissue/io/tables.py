"""Plain CSV tables with ``#`` comment lines (provenance, units, a synthetic label) above a header row.

Format::

    # synthetic: yes -- simulated replica, not measured
    # noise_sd_mm: 0.02
    time_s,displacement_mm,force_mN
    0,0,0
    ...

Column names carry their unit as a suffix (``_s``, ``_mm``, ``_mN``, ``_um``). Comment lines of the form
``# key: value`` are returned as metadata.
"""

from __future__ import annotations

import csv
import io as _io
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError

__all__ = ["read_table", "write_table"]


def read_table(path: str | Path, *, required: tuple[str, ...] = ()) -> tuple[dict[str, np.ndarray], dict]:
    """Read a CSV table with ``#`` comment lines.

    Parameters
    ----------
    path : path of the CSV file.
    required : column names that must be present.

    Returns
    -------
    columns : dict of column name -> 1-D ndarray (float where every entry parses as a number, else str).
    meta : dict of ``key: value`` pairs from the comment lines (values as str).

    Raises
    ------
    FileNotFoundError if the file does not exist; ValidationError for a missing column or ragged rows.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"table file {str(path)!r} does not exist")
    meta: dict[str, str] = {}
    body: list[str] = []
    for line in path.read_text().splitlines():
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            k, sep, v = s.lstrip("#").partition(":")
            if sep:
                meta[k.strip()] = v.strip()
            continue
        body.append(line)
    if not body:
        raise ValidationError(f"{path.name}", "an empty table", "a header row and data rows")
    rows = list(csv.reader(_io.StringIO("\n".join(body))))
    header = [h.strip() for h in rows[0]]
    for k, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise ValidationError(
                f"{path.name} data row {k - 1}",
                ",".join(row),
                f"{len(header)} comma-separated values",
            )
    columns: dict[str, np.ndarray] = {}
    for j, name in enumerate(header):
        raw = [r[j].strip() for r in rows[1:]]
        try:
            columns[name] = np.array([float(x) for x in raw], dtype=float)
        except ValueError:
            columns[name] = np.array(raw, dtype=str)
    missing = [c for c in required if c not in columns]
    if missing:
        raise ValidationError(f"{path.name} columns", header, f"columns {list(required)}", f"missing {missing}")
    return columns, meta


def write_table(
    path: str | Path,
    columns: dict[str, np.ndarray],
    *,
    meta: dict | None = None,
    fmt: str = "%.10g",
) -> Path:
    """Write ``columns`` (equal-length 1-D arrays) as CSV with ``# key: value`` comment lines first."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = list(columns)
    arrays = [np.asarray(columns[n]) for n in names]
    n = {a.shape[0] for a in arrays}
    if len(n) != 1:
        raise ValidationError("columns", {k: a.shape for k, a in zip(names, arrays, strict=True)}, "equal lengths")
    with path.open("w", newline="") as fh:
        for k, v in (meta or {}).items():
            fh.write(f"# {k}: {v}\n")
        fh.write(",".join(names) + "\n")
        for i in range(n.pop()):
            cells = []
            for a in arrays:
                x = a[i]
                cells.append(fmt % x if np.issubdtype(a.dtype, np.number) else str(x))
            fh.write(",".join(cells) + "\n")
    return path

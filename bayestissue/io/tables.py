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
from collections.abc import Callable
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError

__all__ = ["read_table", "write_table"]


def _decode(path: Path) -> str:
    """The file's text: UTF-8 (a byte-order mark, as spreadsheet programs write it, is dropped) or UTF-16 with its
    byte-order mark; anything else is refused with the position of the first byte that is not UTF-8."""
    raw = path.read_bytes()
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            return raw.decode("utf-16")
        except UnicodeDecodeError:
            pass
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValidationError(
            path.name, f"byte 0x{raw[exc.start]:02x} at position {exc.start}", "UTF-8 text (save the file as UTF-8 CSV)"
        ) from None


def _number(text: str) -> float:
    """A cell as a number; ``float`` also takes "nan", "inf" and "1_000", which no data file means."""
    if not text or text.lower().lstrip("+-") in ("nan", "inf", "infinity") or "_" in text:
        raise ValueError(text)
    return float(text)


def read_table(
    path: str | Path,
    *,
    required: tuple[str, ...] = (),
    numeric: bool | tuple[str, ...] | Callable[[str], bool] = False,
) -> tuple[dict[str, np.ndarray], dict]:
    """Read a CSV table with ``#`` comment lines.

    Parameters
    ----------
    path : path of the CSV file (UTF-8, with or without a byte-order mark, or UTF-16 with one).
    required : column names that must be present.
    numeric : the columns whose every cell must be a finite number: True (all), False (none, the default), their
        names, or a test of a column's name; the other columns are numbers where every cell parses as one (``nan``
        included), else text.

    Returns
    -------
    columns : dict of column name -> 1-D ndarray (float, or str for a text column).
    meta : dict of ``key: value`` pairs from the comment lines (values as str).

    Raises
    ------
    FileNotFoundError if the file does not exist; ValidationError naming the file, the line and the column for an
    undecodable file, an empty or duplicated column name, a missing column, a ragged row or a cell that is not a
    number (``n/a``, a decimal comma).
    """
    path = Path(path)
    if path.is_dir():  # e.g. [data] file = "" names the experiment's own folder
        raise ValidationError("table file", str(path), "a CSV file (this is a folder)")
    if not path.is_file():
        raise FileNotFoundError(f"table file {str(path)!r} does not exist")
    text = _decode(path)
    meta, header_line, header = _header(text, path.name)
    if isinstance(numeric, bool):
        must = set(header) if numeric else set()
    else:
        must = {h for h in header if (numeric(h) if callable(numeric) else h in numeric)}
    values = _numbers_fast(text, header_line, len(header)) if must == set(header) else None
    if values is not None:
        columns = {name: values[:, j].copy() for j, name in enumerate(header)}
    else:
        columns = _columns(text, header_line, header, must, path.name)
    missing = [c for c in required if c not in columns]
    if missing:
        raise ValidationError(f"{path.name} columns", header, f"columns {list(required)}", f"missing {missing}")
    return columns, meta


def _header(text: str, name: str) -> tuple[dict, int, list[str]]:
    """The ``# key: value`` lines above the header, the header's line number (1-based) and its column names."""
    meta: dict[str, str] = {}
    for n, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            k, sep, v = s.lstrip("#").partition(":")
            if sep:
                meta[k.strip()] = v.strip()
            continue
        raw = next(csv.reader([line]))
        header = [h.strip() for h in raw]
        where = f"{name} line {n} (header)"
        if "" in header:
            raise ValidationError(where, ",".join(raw), "a name for every column")
        dup = sorted({h for h in header if header.count(h) > 1})
        if dup:
            raise ValidationError(where, ",".join(header), "distinct column names", f"{dup} repeated")
        return meta, n, header
    raise ValidationError(name, "an empty table", "a header row and data rows")


def _numbers_fast(text: str, header_line: int, n_columns: int) -> np.ndarray | None:
    """The rows below the header as an (n, n_columns) float array, parsed in C (a 10^6-row file in about a second and
    no per-cell Python objects); None when anything is amiss (a text cell, a ragged row, a non-finite value), for
    :func:`_columns` to name the line and column."""
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "empty input" and the like: judged below
            a = np.loadtxt(_io.StringIO(text), delimiter=",", comments="#", skiprows=header_line, ndmin=2)
    except ValueError:
        return None
    if a.shape[0] == 0 or a.shape[1] != n_columns or not np.all(np.isfinite(a)):
        return None
    return a


def _columns(text: str, header_line: int, header: list[str], must: set, name: str) -> dict[str, np.ndarray]:
    """Row-by-row reading with the line and column of the first bad cell (the slow path)."""
    body, line_no = [], []
    for n, line in enumerate(text.splitlines()[header_line:], start=header_line + 1):
        s = line.strip()
        if s and not s.startswith("#"):
            body.append(line)
            line_no.append(n)
    if not body:
        raise ValidationError(name, "a header without data rows", "a header row and data rows")
    rows = list(csv.reader(body))
    for row, n in zip(rows, line_no, strict=True):
        if len(row) != len(header):
            hint = "a decimal comma? use a point" if len(row) > len(header) else None
            raise ValidationError(f"{name} line {n}", ",".join(row), f"{len(header)} comma-separated values", hint)
    columns: dict[str, np.ndarray] = {}
    for j, col in enumerate(header):
        raw = [r[j].strip() for r in rows]
        parse = _number if col in must else float
        try:
            columns[col] = np.array([parse(x) for x in raw], dtype=float)
        except ValueError:
            if col not in must:
                columns[col] = np.array(raw, dtype=str)
                continue
            k = next(k for k, x in enumerate(raw) if not _is_number(x))
            raise ValidationError(
                f"{name} line {line_no[k]} column {col}", raw[k], "a finite number (decimal point)"
            ) from None
    return columns


def _is_number(text: str) -> bool:
    try:
        _number(text)
    except ValueError:
        return False
    return True


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
        if all(np.issubdtype(a.dtype, np.number) for a in arrays):  # in C: a 10^6-row curve in about a second
            np.savetxt(fh, np.column_stack(arrays) if arrays else np.empty((0, 0)), fmt=fmt, delimiter=",")
            return path
        for i in range(n.pop()):
            cells = []
            for a in arrays:
                x = a[i]
                cells.append(fmt % x if np.issubdtype(a.dtype, np.number) else str(x))
            fh.write(",".join(cells) + "\n")
    return path

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
    numeric: bool | tuple[str, ...] | Callable[[str], bool] = True,
) -> tuple[dict[str, np.ndarray], dict]:
    """Read a CSV table with ``#`` comment lines.

    Parameters
    ----------
    path : path of the CSV file (UTF-8, with or without a byte-order mark, or UTF-16 with one).
    required : column names that must be present.
    numeric : the columns whose every cell must be a finite number: True (all), False (none), their names, or a
        test of a column's name; the other columns are numbers where every cell parses as one, else text.

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
    if not path.is_file():
        raise FileNotFoundError(f"table file {str(path)!r} does not exist")
    meta: dict[str, str] = {}
    body: list[str] = []
    line_no: list[int] = []
    for n, line in enumerate(_decode(path).splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            k, sep, v = s.lstrip("#").partition(":")
            if sep:
                meta[k.strip()] = v.strip()
            continue
        body.append(line)
        line_no.append(n)
    if not body:
        raise ValidationError(f"{path.name}", "an empty table", "a header row and data rows")
    rows = list(csv.reader(_io.StringIO("\n".join(body))))
    header = [h.strip() for h in rows[0]]
    where = f"{path.name} line {line_no[0]} (header)"
    if "" in header:
        raise ValidationError(where, ",".join(rows[0]), "a name for every column")
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise ValidationError(where, ",".join(header), "distinct column names", f"{dup} repeated")
    for k, row in enumerate(rows[1:], start=1):
        if len(row) != len(header):
            hint = "a decimal comma? use a point" if len(row) > len(header) else None
            raise ValidationError(
                f"{path.name} line {line_no[k]}", ",".join(row), f"{len(header)} comma-separated values", hint
            )
    if isinstance(numeric, bool):
        must = set(header) if numeric else set()
    else:
        must = {h for h in header if (numeric(h) if callable(numeric) else h in numeric)}
    columns: dict[str, np.ndarray] = {}
    for j, name in enumerate(header):
        raw = [r[j].strip() for r in rows[1:]]
        try:
            columns[name] = np.array([_number(x) for x in raw], dtype=float)
        except ValueError:
            if name not in must:
                columns[name] = np.array(raw, dtype=str)
                continue
            for k, x in enumerate(raw, start=1):
                try:
                    _number(x)
                except ValueError:
                    raise ValidationError(
                        f"{path.name} line {line_no[k]} column {name}", x, "a finite number (decimal point)"
                    ) from None
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

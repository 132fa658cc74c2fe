"""Raw testing-machine exports -> an experiment (TOML + tidy CSV) for ``bayestissue import``.

Accepted shape (a CSV as materials-testing software writes it; comma, semicolon or tab separated):

    Specimen label,tendon_07                 metadata lines: "key,value" or "key: value" (any order)
    Diameter,2.1,mm                          or Width and Thickness; an optional unit cell or "(mm)" in the key
    Gauge length (mm),25.0                   or "Gauge length: 25 mm"
                                             blank lines are skipped
    Time,Extension,Load                      the header row: a time, an extension (or displacement) and a load
    (s),(mm),(N)                             (or force) column, in any order, other columns ignored
    0.0,0.000,0.000                          the units row: one unit per column, in () or [] or bare
    ...

Units converted to the experiment's (s, mm, mN): time s, ms, min, h; length mm, um, cm, m, in; force N, mN, kN,
gf, kgf, lbf. The specimen's cross-section becomes the model's square block of the same area (a diameter d gives
sides sqrt(pi d^2 / 4); width x thickness is kept). Trimming: at a chosen time (``until_s``), and after failure:
the first sample after the peak load where the load falls below ``drop`` times the peak (default 0.5; the sample
before the fall is kept). Decimation: to a data step (``step_s``), by linear interpolation at multiples of the step.
Every refusal names the file, the line and what was expected (exit status 2 from the command line).
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.io.tables import _decode

__all__ = ["MachineExport", "read_machine_export", "prepare", "block_section", "UNITS"]

#: unit -> (quantity, factor to s / mm / mN)
UNITS = {
    "s": ("time", 1.0), "sec": ("time", 1.0), "ms": ("time", 1e-3), "min": ("time", 60.0), "h": ("time", 3600.0),
    "mm": ("length", 1.0), "um": ("length", 1e-3), "µm": ("length", 1e-3), "cm": ("length", 10.0),
    "m": ("length", 1e3), "in": ("length", 25.4),
    "n": ("force", 1e3), "mn": ("force", 1.0), "kn": ("force", 1e6), "gf": ("force", 9.80665),
    "kgf": ("force", 9.80665e3), "lbf": ("force", 4448.2216152605),
}  # fmt: skip
#: header names (lower case) of each column role
COLUMNS = {
    "time": ("time", "t", "elapsed time", "test time"),
    "length": ("extension", "displacement", "position", "elongation", "crosshead", "stroke"),
    "force": ("load", "force", "standard force"),
}
#: metadata keys (lower case, unit stripped) -> field
META = {
    "specimen": "label", "specimen label": "label", "label": "label", "sample": "label", "name": "label",
    "diameter": "diameter_mm", "width": "width_mm", "thickness": "thickness_mm",
    "gauge length": "gauge_mm", "gage length": "gauge_mm", "length": "gauge_mm",
}  # fmt: skip


@dataclass
class MachineExport:
    """What an export held, converted to s, mm and mN (``source`` names the file)."""

    source: str
    time_s: np.ndarray
    extension_mm: np.ndarray
    force_mN: np.ndarray
    label: str | None = None
    gauge_mm: float | None = None
    section_mm: tuple[float, float] | None = None  # the model's block: (L_y, L_z)
    section_note: str = ""
    units: dict = field(default_factory=dict)


def _unit(text: str) -> str:
    return text.strip().strip("()[]").strip().lower()


def _split_key(key: str) -> tuple[str, str | None]:
    """``"Gauge length (mm)"`` -> ("gauge length", "mm")."""
    m = re.match(r"^(.*?)\s*[(\[]\s*([^)\]]+)\s*[)\]]\s*$", key)
    if m:
        return m.group(1).strip().lower(), m.group(2).strip().lower()
    return key.strip().lower(), None


def _cells(line: str, delimiter: str) -> list[str]:
    return [c.strip() for c in next(csv.reader([line], delimiter=delimiter))]


def _length(name: str, value: str, unit: str | None, where: str) -> float:
    unit = (unit or "mm").lower()
    if unit not in UNITS or UNITS[unit][0] != "length":
        raise ValidationError(f"{where} {name} unit", unit, f"a length unit among {_units('length')}")
    try:
        x = float(value) * UNITS[unit][1]
    except ValueError:
        raise ValidationError(f"{where} {name}", value, "a number") from None
    if not (math.isfinite(x) and x > 0):
        raise ValidationError(f"{where} {name}", value, "a length > 0")
    return x


def _units(quantity: str) -> list[str]:
    return [u for u, (q, _) in UNITS.items() if q == quantity and u != "µm"]


def _role(name: str) -> str | None:
    n = name.strip().lower()
    return next((role for role, names in COLUMNS.items() if n in names), None)


def read_machine_export(path: str | Path) -> MachineExport:
    """Parse a raw export (module docstring). Raises ValidationError with the file, the line and what was expected."""
    path = Path(path)
    text = _decode(path)
    lines = text.splitlines()
    delimiter = max((",", ";", "\t"), key=lambda d: sum(line.count(d) for line in lines[:40]))
    meta, header_at = {}, None
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        cells = _cells(line, delimiter)
        roles = [_role(c) for c in cells]
        if {"time", "length", "force"} <= set(roles):
            header_at = i
            break
        if len(cells) == 1 and ":" in cells[0]:
            cells = [s.strip() for s in cells[0].split(":", 1)]
        key, unit = _split_key(cells[0])
        if key in META and len(cells) >= 2:
            value = cells[1]
            m = re.fullmatch(r"([-+0-9.eE]+)\s*([A-Za-zµ]+)", value)  # "1.5 cm": the unit in the value cell
            if m and not unit:
                value, unit = m.group(1), m.group(2)
            meta[META[key]] = (value, unit or (cells[2] if len(cells) > 2 and cells[2] else None), i + 1)
    if header_at is None:
        raise ValidationError(
            f"{path.name} header row",
            "none found",
            "a row naming a time, an extension (or displacement) and a load (or force) column",
            "e.g. Time,Extension,Load",
        )
    names = _cells(lines[header_at], delimiter)
    roles = [_role(c) for c in names]
    col = {role: roles.index(role) for role in ("time", "length", "force")}
    units_line = header_at + 1
    if units_line >= len(lines):
        raise ValidationError(f"{path.name} line {units_line + 1}", "end of file", "a units row, e.g. (s),(mm),(N)")
    unit_cells = _cells(lines[units_line], delimiter)
    factors, units = {}, {}
    for role, j in col.items():
        u = _unit(unit_cells[j]) if j < len(unit_cells) else ""
        if u not in UNITS or UNITS[u][0] != role:
            raise ValidationError(
                f"{path.name} line {units_line + 1} unit of {names[j]!r}", u or "nothing",
                f"a {role} unit among {_units(role)}",
            )  # fmt: skip
        factors[role], units[role] = UNITS[u][1], unit_cells[j].strip()
    rows = []
    for i in range(units_line + 1, len(lines)):
        if not lines[i].strip():
            continue
        cells = _cells(lines[i], delimiter)
        row = []
        for role, j in col.items():
            cell = cells[j] if j < len(cells) else ""
            try:
                x = float(cell)
            except ValueError:
                x = math.nan
            if not math.isfinite(x):
                hint = "a decimal comma? save with decimal points" if re.fullmatch(r"-?\d+,\d+", cell) else None
                raise ValidationError(f"{path.name} line {i + 1} column {names[j]!r}", cell, "a number", hint)
            row.append(x * factors[role])
        rows.append(row)
    if len(rows) < 2:
        raise ValidationError(f"{path.name} data rows", len(rows), "at least 2 rows after the units row")
    data = np.array(rows)
    t = data[:, 0]
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        line = units_line + 2 + int(bad[0]) + 1
        raise ValidationError(f"{path.name} line {line} time", float(t[bad[0] + 1]), "times increasing row by row")
    out = MachineExport(str(path), t - t[0], data[:, 1] - data[0, 1], data[:, 2], units=units)
    if "label" in meta:
        out.label = meta["label"][0]
    if "gauge_mm" in meta:
        v, u, line = meta["gauge_mm"]
        out.gauge_mm = _length("gauge length", v, u, f"{path.name} line {line}")
    if "diameter_mm" in meta:
        v, u, line = meta["diameter_mm"]
        out.section_mm, out.section_note = block_section(
            diameter_mm=_length("diameter", v, u, f"{path.name} line {line}")
        )
    elif "width_mm" in meta and "thickness_mm" in meta:
        (vw, uw, lw), (vt, ut, lt) = meta["width_mm"], meta["thickness_mm"]
        w = _length("width", vw, uw, f"{path.name} line {lw}")
        out.section_mm, out.section_note = block_section(
            width_mm=w, thickness_mm=_length("thickness", vt, ut, f"{path.name} line {lt}")
        )
    return out


def block_section(*, diameter_mm=None, width_mm=None, thickness_mm=None) -> tuple[tuple[float, float], str]:
    r"""The model block's cross-section ``(L_y, L_z)`` and a line saying how it was made: a round specimen as the
    square of the same area (side :math:`\sqrt{\pi d^2 / 4}`), a rectangular one as it is."""
    if diameter_mm is not None:
        side = math.sqrt(math.pi * diameter_mm * diameter_mm / 4.0)
        return (side, side), f"circular, diameter {diameter_mm:g} mm: a square of the same area, side {side:.6g} mm"
    return (width_mm, thickness_mm), f"width {width_mm:g} mm x thickness {thickness_mm:g} mm"


def prepare(export: MachineExport, *, until_s=None, drop: float | None = 0.5, step_s=None) -> tuple[dict, str]:
    """Trim and decimate ``export``: returns the tidy columns ``time_s``, ``displacement_mm``, ``force_mN`` and a
    line saying what was done."""
    t, u, f = export.time_s, export.extension_mm, export.force_mN
    keep = np.ones(t.size, dtype=bool)
    notes = []
    if until_s is not None:
        keep &= t <= until_s
        notes.append(f"cut at t = {until_s:g} s")
    if drop is not None:
        peak = int(np.argmax(np.where(keep, f, -np.inf)))
        after = np.flatnonzero((np.arange(t.size) > peak) & (f < drop * f[peak]))
        if after.size:
            keep &= np.arange(t.size) < after[0]
            notes.append(f"failure: load below {drop:g} x peak ({f[peak]:.4g} mN) from t = {t[after[0]]:.4g} s on")
    t, u, f = t[keep], u[keep], f[keep]
    if t.size < 2:
        raise ValidationError(f"{Path(export.source).name} rows left after trimming", t.size, "at least 2")
    if step_s is not None:
        grid = np.arange(0.0, t[-1] + 1e-9 * step_s, step_s)
        u, f, t = np.interp(grid, t, u), np.interp(grid, t, f), grid
        notes.append(f"resampled every {step_s:g} s (linear interpolation)")
    return {"time_s": t, "displacement_mm": u, "force_mN": f}, "; ".join(notes) or "no trimming"

"""Raw testing-machine exports -> :class:`MachineExport` (time, extension, load in s, mm, mN, and the specimen's
dimensions), for ``bayestissue import``; trimming and resampling: :mod:`bayestissue.io.export_prepare`.

The shape every supported machine writes: metadata lines, then a header row naming the columns and a units row, then
the data (comma, semicolon or tab separated; cells may be quoted). The styles read (fixtures of each, in their
documented layouts, in ``tests/cli/exports/``):

* Instron Bluehill (``Specimen_RawData_1.csv``): ``Specimen properties : Diameter,"0.37600",mm`` (a section prefix
  before `` : ``), ``Test : Rate 1,"5.00000",mm/min``, a blank line, ``Extension,Load,Tensile stress,Time`` and
  ``(mm),(N),(MPa),(s)``, quoted numbers;
* MTS TestSuite (tab separated): ``Specimen Name:<TAB>t3``, ``Diameter:<TAB>0.41<TAB>mm``, then
  ``Time<TAB>Axial Displacement<TAB>Axial Force`` and bare units ``sec<TAB>mm<TAB>N``;
* Zwick testXpert (semicolons, decimal commas): the ISO 6892 symbols ``d0;0,376;mm``, ``L0;14,33;mm`` (``a0``
  thickness, ``b0`` width), then ``Test time;Standard travel;Standard force`` and ``s;mm;N``;
* the generic form: ``Specimen label,tendon_07``, ``Diameter,2.1,mm``, ``Gauge length (mm),25.0`` or
  ``Gage length: 1.5 cm``, ``Time,Extension,Load`` and ``(s),(mm),(N)`` (units in (), [] or bare).

Metadata keys are matched without their section prefix, unit or case (:data:`META`); a metadata line that is not
understood is skipped and named (:attr:`MachineExport.skipped`); the same key twice with different values is
refused. Units converted to the experiment's (s, mm, mN): time s, ms, min, h; length mm, um, cm, m, in; force N, mN,
kN, gf, kgf, lbf. The specimen's cross-section becomes the model's square block of the same area (a diameter d gives
sides sqrt(pi d^2 / 4); width x thickness is kept). Every refusal names the file, the line and what was expected
(exit status 2 from the command line).
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

__all__ = ["MachineExport", "read_machine_export", "block_section", "UNITS"]

#: unit -> (quantity, factor to s / mm / mN)
UNITS = {
    "s": ("time", 1.0), "sec": ("time", 1.0), "secs": ("time", 1.0), "ms": ("time", 1e-3), "min": ("time", 60.0),
    "h": ("time", 3600.0),
    "mm": ("length", 1.0), "um": ("length", 1e-3), "µm": ("length", 1e-3), "cm": ("length", 10.0),
    "m": ("length", 1e3), "in": ("length", 25.4),
    "n": ("force", 1e3), "mn": ("force", 1.0), "kn": ("force", 1e6), "gf": ("force", 9.80665),
    "kgf": ("force", 9.80665e3), "lbf": ("force", 4448.2216152605),
}  # fmt: skip
#: header names (lower case) of each column role
COLUMNS = {
    "time": ("time", "t", "elapsed time", "test time", "running time", "prüfzeit"),
    "length": ("extension", "displacement", "position", "elongation", "crosshead", "stroke", "axial displacement",
               "standard travel", "grip to grip separation", "standardweg", "traversenweg"),
    "force": ("load", "force", "standard force", "axial force", "standardkraft"),
}  # fmt: skip
#: metadata keys (lower case, section prefix and unit stripped) -> field; a0, b0, d0, L0: the symbols of ISO 6892-1
META = {
    "specimen": "label", "specimen label": "label", "label": "label", "sample": "label", "name": "label",
    "specimen name": "label", "specimen id": "label",
    "diameter": "diameter_mm", "specimen diameter": "diameter_mm", "d0": "diameter_mm",
    "width": "width_mm", "specimen width": "width_mm", "b0": "width_mm",
    "thickness": "thickness_mm", "specimen thickness": "thickness_mm", "a0": "thickness_mm",
    "gauge length": "gauge_mm", "gage length": "gauge_mm", "length": "gauge_mm", "initial gauge length": "gauge_mm",
    "specimen gauge length": "gauge_mm", "l0": "gauge_mm",
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
    #: metadata lines before the header that were not understood: (line number, text)
    skipped: list = field(default_factory=list)


def _unit(text: str) -> str:
    return text.strip().strip("()[]").strip().lower()


def _split_key(key: str) -> tuple[str, str | None]:
    """``"Gauge length (mm)"`` -> ("gauge length", "mm"); ``"Specimen properties : Diameter"`` -> ("diameter", None)
    (Bluehill's section prefix dropped)."""
    key = key.rsplit(" : ", 1)[-1]
    m = re.match(r"^(.*?)\s*[(\[]\s*([^)\]]+)\s*[)\]]\s*$", key)
    if m:
        return m.group(1).strip().lower(), m.group(2).strip().lower()
    return key.strip().rstrip(":").strip().lower(), None


def _cells(line: str, delimiter: str) -> list[str]:
    return [c.strip() for c in next(csv.reader([line], delimiter=delimiter))]


def _length(name: str, value: str, unit: str | None, where: str) -> float:
    unit = (unit or "mm").lower()
    if unit not in UNITS or UNITS[unit][0] != "length":
        raise ValidationError(f"{where} {name} unit", unit, f"a length unit among {_units('length')}")
    try:
        x = float(_decimal_point(value)) * UNITS[unit][1]
    except ValueError:
        raise ValidationError(f"{where} {name}", value, "a number") from None
    if not (math.isfinite(x) and x > 0):
        raise ValidationError(f"{where} {name}", value, "a length > 0")
    return x


def _units(quantity: str) -> list[str]:
    return [u for u, (q, _) in UNITS.items() if q == quantity and u != "µm"]


def _decimal_point(cell: str) -> str:
    """``"0,376"`` -> ``"0.376"`` (a decimal comma, as German and French locales write; only where the cells are
    separated by semicolons or tabs, so that a comma cannot be a separator)."""
    return cell.replace(",", ".", 1) if re.fullmatch(r"[-+]?\d*,\d+([eE][-+]?\d+)?", cell) else cell


def _role(name: str) -> str | None:
    n = name.strip().lower()
    return next((role for role, names in COLUMNS.items() if n in names), None)


def _is_header(cells: list[str]) -> bool:
    """A row naming a time, an extension and a load column (the data's header)."""
    return {"time", "length", "force"} <= {_role(c) for c in cells}


def _delimiter(lines: list[str]) -> str:
    """The separator under which a header row (time, extension, load) appears among the first lines: tab, then
    semicolon, then comma (a file with decimal commas has more commas than semicolons); else the most frequent."""
    for d in ("\t", ";", ","):
        for line in lines[:500]:
            if d in line and _is_header(_cells(line, d)):
                return d
    return max((",", ";", "\t"), key=lambda d: sum(line.count(d) for line in lines[:40]))


def _same(a: tuple, b: tuple) -> bool:
    """Two metadata entries (value, unit, line) state the same: equal units and equal numbers (or equal text)."""
    if (a[1] or "").lower() != (b[1] or "").lower():
        return False
    try:
        return float(_decimal_point(a[0])) == float(_decimal_point(b[0]))
    except ValueError:
        return a[0] == b[0]


def _metadata(lines, delimiter, name):
    """The metadata lines before the header row: ({field: (value, unit, line)}, skipped lines, header row index)."""
    meta, skipped = {}, []
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        cells = _cells(line, delimiter)
        if _is_header(cells):
            return meta, skipped, i
        if len(cells) == 1 and ":" in cells[0]:
            cells = [s.strip() for s in cells[0].rsplit(":", 1)]
        key, unit = _split_key(cells[0])
        if key not in META or len(cells) < 2 or not cells[1]:
            skipped.append((i + 1, line.strip()))
            continue
        value = cells[1]
        m = re.fullmatch(r"([-+0-9.,eE]+)\s*([A-Za-zµ]+)", value)  # "1.5 cm": the unit in the value cell
        if m and not unit:
            value, unit = m.group(1), m.group(2)
        entry = (value, unit or (cells[2] if len(cells) > 2 and cells[2] else None), i + 1)
        field_ = META[key]
        if field_ in meta and not _same(meta[field_], entry):
            first = meta[field_]
            raise ValidationError(
                f"{name} lines {first[2]} and {i + 1} {cells[0]!r}",
                f"{first[0]} {first[1] or ''} and {entry[0]} {entry[1] or ''}".replace("  ", " ").strip(),
                "one value (the export states this quantity twice, differently)",
            )  # fmt: skip
        meta[field_] = entry
    raise ValidationError(
        f"{name} header row",
        "none found",
        "a row naming a time, an extension (or displacement) and a load (or force) column",
        "e.g. Time,Extension,Load",
    )


def read_machine_export(path: str | Path) -> MachineExport:
    """Parse a raw export (module docstring). Raises ValidationError with the file, the line and what was expected."""
    path = Path(path)
    if path.is_dir():
        raise ValidationError(str(path), "a folder", "a testing machine's CSV export (a file)")
    text = _decode(path)
    lines = text.splitlines()
    delimiter = _delimiter(lines)
    number = _decimal_point if delimiter != "," else (lambda cell: cell)
    meta, skipped, header_at = _metadata(lines, delimiter, path.name)
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
                x = float(number(cell))
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
    out = MachineExport(str(path), t - t[0], data[:, 1] - data[0, 1], data[:, 2], units=units, skipped=skipped)
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

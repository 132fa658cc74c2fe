"""The experiment file's schema: which tables and keys exist, and the type of each value.

:func:`check_experiment_document` runs on the parsed TOML before anything is built from it, so that a typo
(``stres_kpa``, ``length_w_mm``, ``[tissue] fibre_directions``) is refused with the nearest valid name instead of
being ignored, and a value of the wrong type (``length_x_mm = true``, ``dt_s = "6"``) is refused instead of being
converted. Ranges (a positive length, fractions summing to 1, unit directions) are checked where the objects are
built (:class:`~bayestissue.mechanics.experiment.Experiment`, the protocols, :class:`~.tissue.TissueConfig`),
against the values the checks here let through.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from bayestissue._validation import ValidationError, check_known_keys

__all__ = ["TABLES", "PROTOCOL_KEYS", "check_experiment_document"]


def _number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _numbers(v) -> bool:
    return isinstance(v, list) and all(_number(x) for x in v)


def _rows(v) -> bool:
    return isinstance(v, list) and all(_numbers(r) for r in v)


#: value kind -> (test, what the message says is expected)
_KINDS = {
    "text": (lambda v: isinstance(v, str), "a string"),
    "bool": (lambda v: isinstance(v, bool), "true or false"),
    "number": (_number, "a number"),
    "numbers": (_numbers, "a list of numbers"),
    "rows": (_rows, "a list of [x, y, z] rows"),
}

#: The keys of each table ("" is the top level, whose tables are checked with their own keys).
TABLES: dict[str, dict[str, str]] = {
    "": {"name": "text", "description": "text", "synthetic": "bool"},
    "specimen": {"length_x_mm": "number", "length_y_mm": "number", "length_z_mm": "number"},
    "protocol": {
        "kind": "text",
        "stress_kpa": "number",
        "hold_stress_kpa": "number",
        "hold_s": "number",
        "rate_kpa_per_s": "number",
        "force_column": "text",
    },
    "simulation": {"dt_s": "number"},
    "data": {"file": "text", "duration_s": "number", "step_s": "number"},
    "tissue": {
        "directions": "rows",
        "phi_fibres": "numbers",
        "phi_matrix": "number",
        "bulk_kpa": "number",
        "eps0": "numbers",
    },
}

#: The ``[protocol]`` keys each kind takes (a ramp's ``stress_kpa`` is a mistake, not an extra).
PROTOCOL_KEYS = {
    "creep": ("kind", "stress_kpa"),
    "ramp": ("kind", "hold_stress_kpa", "hold_s", "rate_kpa_per_s"),
    "measured": ("kind", "force_column"),
}


def _check_table(table: Mapping, keys: Mapping[str, str], file: str, prefix: str, known: list[str]) -> None:
    label = f"[{prefix[:-1]}]" if prefix else "top-level"
    check_known_keys(f"{file} {label} key", table, known)
    for key, value in table.items():
        if key in keys:
            ok, expected = _KINDS[keys[key]]
            if not ok(value):
                raise ValidationError(f"{file} {prefix}{key}", value, expected)


def check_experiment_document(doc: Mapping, file: str) -> None:
    """Check a parsed experiment file's tables, keys and value types; ``file`` names it in the messages.

    Raises
    ------
    ValidationError
        ``<file> <table>.<key>: expected ..., got ...``; an unknown key or table is named with the nearest valid
        one.
    """
    tables = [t for t in TABLES if t]
    top = {k: v for k, v in doc.items() if not isinstance(v, Mapping)}
    _check_table(top, TABLES[""], file, "", [*TABLES[""], *tables])
    for name, table in doc.items():
        if not isinstance(table, Mapping):
            continue
        check_known_keys(f"{file} table", {f"[{name}]": None}, [f"[{t}]" for t in tables])
        keys = TABLES[name]
        known = list(keys)
        if name == "protocol" and table.get("kind") in PROTOCOL_KEYS:
            known = list(PROTOCOL_KEYS[table["kind"]])
        _check_table(table, keys, file, f"{name}.", known)

"""One typed schema for every TOML file the tool reads: a key's kind, range, default and meaning, checked before any
work and rendered as the reference documentation.

A table of keys is a ``dict[str, Key]``. :func:`check_table` refuses an unknown key (naming the nearest valid one), a
value of the wrong type (``"50"`` for a number, ``true`` for a count or a length: TOML booleans are not numbers here)
and a number out of range; :func:`reference_rows` renders the same keys as Markdown table rows. The calibration
configuration (:mod:`bayestissue.workflows.schema`, ``docs/config.md``) and the experiment files
(:mod:`bayestissue.mechanics.experiment_schema`, ``docs/experiment.md``) are both written in it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from bayestissue._validation import ValidationError, check_known_keys
from bayestissue.parallel import RUN_TARGET_TEXT, is_run_target

__all__ = ["Key", "check_table", "expected", "reference_rows", "valid"]


@dataclass(frozen=True)
class Key:
    """One key: ``kind`` (see :func:`valid`), default (as text), meaning; ``low`` an inclusive lower bound of a
    number (``low_open`` makes it exclusive), ``high`` an inclusive upper one (sizes that would exhaust memory or
    never finish); ``choices`` the allowed strings."""

    kind: str
    default: str
    doc: str
    low: float | None = None
    low_open: bool = False
    choices: tuple = ()
    high: float | None = None


def _is_number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _is_numbers(v) -> bool:
    return isinstance(v, list) and all(_is_number(x) for x in v)


def _is_names(v) -> bool:
    return isinstance(v, list) and all(isinstance(x, str) for x in v)


def _is_pair(v) -> bool:
    return isinstance(v, list) and len(v) == 2 and all(_is_number(x) for x in v)


def _is_table(v, value_ok) -> bool:
    return isinstance(v, Mapping) and all(value_ok(x) for x in v.values())


def _in_range(v, key: Key) -> bool:
    above = key.low is None or (v > key.low if key.low_open else v >= key.low)
    return above and (key.high is None or v <= key.high)


def expected(key: Key) -> str:
    """What ``key`` expects, as the error message and the reference say it."""
    bound = "" if key.low is None else f" {'>' if key.low_open else '>='} {key.low:g}"
    bound += "" if key.high is None else f"{' and' if bound else ''} <= {key.high:g}"
    return {
        "int": f"an integer{bound}",
        "float": f"a number{bound}",
        "bool": "true or false",
        "text": "a string",
        "choice": f"one of {list(key.choices)}",
        "numbers": "a list of numbers",
        "rows": "a list of [x, y, z] rows",
        "names": "a list of parameter names",
        "fixed": "a table name = value or a list of names",
        "bounds": "a table name = [lower, upper]",
        "name_text": 'a table name = "text"',
        "name_number": "a table name = value",
        "groups": "two lists of parameter names of equal length",
        "pair": "a pair [lower, upper] of numbers",
        "sd": f'a number{bound} or "data"',
        "scheduler": RUN_TARGET_TEXT,
    }[key.kind]


def valid(v, key: Key) -> bool:
    """Whether ``v`` (a parsed TOML value) is what ``key`` expects."""
    k = key.kind
    if k == "int":
        return isinstance(v, int) and not isinstance(v, bool) and _in_range(v, key)
    if k in ("float", "sd"):
        return (k == "sd" and v == "data") or (_is_number(v) and _in_range(v, key))
    if k == "bool":
        return isinstance(v, bool)
    if k == "text":
        return isinstance(v, str)
    if k == "choice":
        return isinstance(v, str) and v in key.choices
    if k == "numbers":
        return _is_numbers(v)
    if k == "rows":
        return isinstance(v, list) and all(_is_numbers(r) and len(r) == 3 for r in v)
    if k == "names":
        return _is_names(v)
    if k == "fixed":
        return _is_names(v) or _is_table(v, _is_number)
    if k == "bounds":
        return _is_table(v, _is_pair)
    if k == "name_text":
        return _is_table(v, lambda x: isinstance(x, str))
    if k == "name_number":
        return _is_table(v, _is_number)
    if k == "groups":
        return isinstance(v, list) and len(v) == 2 and all(_is_names(g) for g in v) and len(v[0]) == len(v[1]) > 0
    if k == "pair":
        return _is_pair(v)
    if k == "scheduler":
        return is_run_target(v)
    raise AssertionError(f"unknown schema kind {k!r}")  # a bug in a schema, not user input


def check_table(table: Mapping, keys: Mapping[str, Key], where: str, *, allowed=None) -> None:
    """Check one table's keys and values; ``where`` prefixes the field in the messages (``"T1.toml [protocol]"``),
    ``allowed`` narrows the known keys (default: all of ``keys``).

    Raises
    ------
    ValidationError
        ``<where> key: expected one of [...], got 'stres_kpa' (did you mean 'stress_kpa'?)`` or
        ``<where> <key>: expected <what>, got <value>``.
    """
    check_known_keys(f"{where} key", table, list(keys) if allowed is None else list(allowed))
    for name, value in table.items():
        if keys[name].kind == "rows" and isinstance(value, list):
            _check_rows(value, f"{where} {name}")
        if not valid(value, keys[name]):
            raise ValidationError(f"{where} {name}", value, expected(keys[name]))


def _check_rows(rows: list, field: str) -> None:
    """The first bad row of an [x, y, z] list, by number: its length, then its entries."""
    for i, row in enumerate(rows, start=1):
        if not isinstance(row, list) or len(row) != 3:
            raise ValidationError(f"{field} row {i}", row, "three numbers [x, y, z]")
        for x in row:
            if not _is_number(x):
                raise ValidationError(f"{field} row {i}", row, "finite numbers")


def reference_rows(keys: Mapping[str, Key]) -> list[str]:
    """The keys as Markdown table rows ``| key | expects | default | meaning |``, with the header."""
    rows = ["| key | expects | default | meaning |", "|---|---|---|---|"]
    return rows + [f"| `{name}` | {expected(key)} | {key.default} | {key.doc} |" for name, key in keys.items()]

"""Typed, versioned result records: what one study stage hands to the next, checked when written and when read.

A record is a dataclass whose class carries ``SCHEMA`` (its name, e.g. ``"bayestissue.controls"``) and ``VERSION``
(an integer raised whenever a field is added, removed, renamed or changes its meaning). Fields are annotated with
``bool``, ``int``, ``float``, ``str``, ``list[T]``, ``tuple[T, ...]``, ``tuple[A, B]``, ``dict[str, T]``,
``T | None`` or another dataclass. :func:`write_record` checks every value against its annotation (numpy scalars and
arrays are accepted where the annotation asks for numbers or lists) and writes

.. code-block:: json

    {"schema": "bayestissue.controls", "version": 1, "record": {...}}

:func:`read_record` checks the schema name, the version, that no field is missing or unknown, and every value's type,
and rebuilds the dataclasses. Non-finite floats are written as the strings ``"inf"``, ``"-inf"`` and ``"nan"`` (JSON
has no such numbers). Every failure is a :class:`RecordError` naming the file and the field's path, so a renamed or
missing field fails in the stage that wrote it (a dataclass refuses an unknown or missing keyword at construction,
:func:`write_record` a wrongly typed value) or, for a file written by other code, in the stage that reads it.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import types
import typing
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from bayestissue._validation import ValidationError

__all__ = ["RecordError", "from_plain", "read_record", "to_plain", "write_record"]

R = TypeVar("R")
_NONFINITE = {"inf": math.inf, "-inf": -math.inf, "nan": math.nan}


class RecordError(ValidationError):
    """A record that does not match its schema: the message names the file (or record) and the field's path."""


def _hints(cls) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _fail(where: str, value, expected: str):
    shown = value if not isinstance(value, dict | list) else type(value).__name__
    raise RecordError(where, shown, expected)


def _convert(value, tp, where: str, *, reading: bool):
    """``value`` checked against the annotation ``tp``; JSON-ready when writing, typed objects when reading."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if tp is Any:
        return value
    if tp is type(None):
        if value is not None:
            _fail(where, value, "null")
        return None
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for alt in (a for a in args if a is not type(None)):
            try:
                return _convert(value, alt, where, reading=reading)
            except RecordError as err:
                errors.append(err.expected)
        _fail(where, value, " or ".join(errors + (["null"] if type(None) in args else [])))
    if tp is bool:
        if not isinstance(value, bool | np.bool_):
            _fail(where, value, "true or false")
        return bool(value)
    if tp is int:
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
            _fail(where, value, "an integer")
        return int(value)
    if tp is float:
        if isinstance(value, str) and value in _NONFINITE:
            return _NONFINITE[value] if reading else value
        if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.integer | np.floating):
            _fail(where, value, "a number")
        x = float(value)
        if reading or math.isfinite(x):
            return x
        return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")
    if tp is str:
        if not isinstance(value, str):
            _fail(where, value, "a string")
        return str(value)
    if origin in (list, tuple):
        if isinstance(value, np.ndarray) and not reading:
            value = value.tolist()
        if not isinstance(value, list | tuple):
            _fail(where, value, "a list")
        if origin is tuple and not (len(args) == 2 and args[1] is Ellipsis):
            if len(value) != len(args):
                _fail(where, value, f"a list of {len(args)} entries")
            pairs = enumerate(zip(value, args, strict=True))
            items = [_convert(v, a, f"{where}[{i}]", reading=reading) for i, (v, a) in pairs]
        else:
            item = args[0] if args else Any
            items = [_convert(v, item, f"{where}[{i}]", reading=reading) for i, v in enumerate(value)]
        return tuple(items) if (origin is tuple and reading) else items
    if origin is dict:
        key_tp, val_tp = args if args else (str, Any)
        if not isinstance(value, dict):
            _fail(where, value, "a table of name -> value")
        out = {}
        for k, v in value.items():
            if key_tp is str and not isinstance(k, str):
                _fail(f"{where} key", k, "a string")
            out[str(k)] = _convert(v, val_tp, f"{where}[{k!r}]", reading=reading)
        return out
    if dataclasses.is_dataclass(tp):
        return _dataclass(value, tp, where, reading=reading)
    raise TypeError(f"{where}: annotation {tp!r} is not supported by bayestissue.io.records")


def _dataclass(value, cls, where: str, *, reading: bool):
    hints = _hints(cls)
    fields = [f.name for f in dataclasses.fields(cls)]
    if reading:
        if not isinstance(value, dict):
            _fail(where, value, f"a table with the fields of {cls.__name__}")
        unknown = [k for k in value if k not in fields]
        if unknown:
            from bayestissue._validation import check_known_keys

            try:
                check_known_keys(f"{where} field", {unknown[0]: None}, fields)
            except ValidationError as err:
                raise RecordError(err.field, err.value, err.expected, err.hint) from None
        missing = [k for k in fields if k not in value]
        if missing:
            _fail(f"{where}.{missing[0]}", "missing", f"a value (every field of {cls.__name__} is written)")
        kwargs = {k: _convert(value[k], hints[k], f"{where}.{k}", reading=True) for k in fields}
        return cls(**kwargs)
    if not isinstance(value, cls):
        _fail(where, type(value).__name__, f"a {cls.__name__}")
    return {k: _convert(getattr(value, k), hints[k], f"{where}.{k}", reading=False) for k in fields}


def to_plain(record, *, where: str | None = None) -> dict:
    """The record as JSON-ready values, every field checked against its annotation (raises :class:`RecordError`)."""
    cls = type(record)
    return _dataclass(record, cls, where or cls.__name__, reading=False)


def from_plain(data, cls: type[R], *, where: str | None = None) -> R:
    """A record of type ``cls`` rebuilt from :func:`to_plain` values (raises :class:`RecordError`)."""
    return _dataclass(data, cls, where or cls.__name__, reading=True)


def write_record(path, record) -> Path:
    """Check ``record`` and write it as versioned JSON to ``path`` (atomically: a killed write leaves the old file)."""
    path = Path(path)
    cls = type(record)
    body = to_plain(record, where=f"{path.name}: {cls.__name__}")
    text = json.dumps({"schema": cls.SCHEMA, "version": cls.VERSION, "record": body}, indent=1, allow_nan=False)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text + "\n")
    os.replace(tmp, path)
    return path


def read_record(path, cls: type[R]) -> R:
    """Read a record of type ``cls`` from ``path``, checking its schema name, version and every field."""
    path = Path(path)
    where = path.name
    if not path.is_file():
        raise RecordError(where, "missing", f"a {cls.SCHEMA} record (run the stage that writes it)")
    try:
        doc = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise RecordError(where, type(err).__name__, "a JSON record") from None
    if not isinstance(doc, dict) or doc.get("schema") != cls.SCHEMA:
        got = doc.get("schema", "no schema") if isinstance(doc, dict) else type(doc).__name__
        raise RecordError(f"{where} schema", got, repr(cls.SCHEMA))
    if doc.get("version") != cls.VERSION:
        raise RecordError(
            f"{where} version", doc.get("version"), f"version {cls.VERSION} (rerun the stage that writes it)"
        )
    return from_plain(doc.get("record"), cls, where=f"{where}: {cls.__name__}")

"""Checks at the public boundary: each raises ``ValueError`` naming the field, the value and what was expected."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

__all__ = [
    "ValidationError",
    "check_known_keys",
    "check_finite",
    "check_interval",
    "check_positive",
    "check_unit_vector",
    "check_increasing",
]


class ValidationError(ValueError):
    """Bad user input. The message names the field, the value received and what was expected."""

    def __init__(self, field: str, value, expected: str, hint: str | None = None):
        if isinstance(value, np.generic):  # np.float64(1e+300) would print as such
            value = value.item()
        self.field, self.value, self.expected, self.hint = field, value, expected, hint
        msg = f"{field}: expected {expected}, got {value!r}"
        if hint:
            msg += f" ({hint})"
        super().__init__(msg)

    def __reduce__(self):  # pickles whole (a task on a dask worker raises it back to the client)
        return (type(self), (self.field, self.value, self.expected, self.hint))

    def within(self, where: str) -> ValidationError:
        """The same error with ``where`` (e.g. the file's name) before the field."""
        return ValidationError(f"{where} {self.field}", self.value, self.expected, self.hint)


def check_known_keys(field: str, mapping, known) -> None:
    """Raise for the first key of ``mapping`` not in ``known``, naming the nearest known key (a typo's fix)."""
    import difflib

    known = list(known)
    for key in mapping:
        if key not in known:
            near = difflib.get_close_matches(str(key), known, n=1, cutoff=0.6)
            hint = f"did you mean {near[0]!r}?" if near else None
            raise ValidationError(field, key, f"one of {known}", hint)


def check_finite(field: str, value) -> float:
    """Return ``value`` as float; raise unless it is a finite real number (``True`` is not the number 1 here)."""
    if isinstance(value, bool | np.bool_):
        raise ValidationError(field, value, "a finite number")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValidationError(field, value, "a finite number") from None
    if not math.isfinite(x):
        raise ValidationError(field, value, "a finite number")
    return x


def check_positive(field: str, value, *, allow_zero: bool = False) -> float:
    """Return ``value`` as float; raise unless it is finite and > 0 (>= 0 with ``allow_zero``)."""
    x = check_finite(field, value)
    if x < 0 or (x == 0 and not allow_zero):
        raise ValidationError(field, value, "a number >= 0" if allow_zero else "a number > 0")
    return x


def check_interval(field: str, value, low: float, high: float, *, closed: tuple[bool, bool] = (True, True)) -> float:
    """Return ``value`` as float; raise unless it lies in the interval between ``low`` and ``high``."""
    x = check_finite(field, value)
    lo_ok = x >= low if closed[0] else x > low
    hi_ok = x <= high if closed[1] else x < high
    if not (lo_ok and hi_ok):
        br = ("[" if closed[0] else "(", "]" if closed[1] else ")")
        raise ValidationError(field, value, f"a number in {br[0]}{low}, {high}{br[1]}")
    return x


def check_unit_vector(field: str, value: Iterable[float], *, tol: float = 1e-2) -> np.ndarray:
    """Return a 3-vector; raise unless it is finite, non-zero and of unit length within ``tol``.

    The paper prints its fibre directions rounded ([0.9369, 0.3420, 0] has |v| = 0.99737), hence the default
    tolerance of 1 %; the returned vector is normalised.
    """
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValidationError(field, list(np.ravel(value)), "a finite 3-vector")
    n = float(np.linalg.norm(v))
    if abs(n - 1.0) > tol:
        raise ValidationError(field, v.tolist(), f"a unit vector (|v| = 1 within {tol}), |v| = {n:.6g}")
    return v / n


def check_increasing(field: str, values) -> np.ndarray:
    """Return a 1-D float array; raise unless it is finite and strictly increasing."""
    a = np.asarray(values, dtype=float)
    if a.ndim != 1 or a.size == 0:
        raise ValidationError(field, f"array of shape {a.shape}", "a non-empty 1-D column")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise ValidationError(field, f"{a[bad[0]]} at row {bad[0]}", "finite values")
    steps = np.diff(a)
    nz = np.flatnonzero(steps <= 0)
    if nz.size:
        i = nz[0]
        raise ValidationError(field, f"{a[i]} then {a[i + 1]} at rows {i}-{i + 1}", "strictly increasing values")
    return a

"""Number formatting and verdict wording shared by the report sections."""

from __future__ import annotations

import numpy as np

__all__ = ["ci_text", "fl", "likelihood_ratio", "num", "short"]


def num(x, fmt=".3g"):
    if x is None:
        return "n/a"
    if isinstance(x, str):
        return "inf" if x == "inf" else x
    return format(float(x), fmt)


def likelihood_ratio(dchi2: float) -> str:
    """:math:`\\exp(\\Delta\\chi^2 / 2)` as text, in powers of ten where it would overflow a float
    (a short --quick run can leave the chains thousands of chi2 units above the best optimum)."""
    half = float(dchi2) / 2.0
    return num(np.exp(half), ".3g") if half < 700.0 else f"1e{half / np.log(10.0):.0f}"


def short(cls):
    return {
        "identifiable": "identifiable",
        "practically non-identifiable": "practically NI",
        "structurally non-identifiable": "structurally NI",
    }.get(cls, cls or "-")


def ci_text(p):
    lo, hi = p["ci"]
    return f"[{num(lo) if lo is not None else 'open'}, {num(hi) if hi is not None else 'open'}]"


def fl(x):
    return float("inf") if x == "inf" else (float("nan") if x is None else float(x))

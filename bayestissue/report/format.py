"""Number formatting for the report template (Jinja2 filters): one place decides how a number reads."""

from __future__ import annotations

import math

__all__ = ["FILTERS", "ci_text", "likelihood_ratio", "names", "num", "pct", "short"]

_SHORT = {
    "identifiable": "identifiable",
    "practically non-identifiable": "practically NI",
    "structurally non-identifiable": "structurally NI",
}


def num(x, fmt: str = ".3g") -> str:
    """``x`` formatted with ``fmt``; ``n/a`` for None, ``inf`` for an infinite value."""
    if x is None:
        return "n/a"
    x = float(x)
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return format(x, fmt)


def pct(x, fmt: str = ".0f") -> str:
    """A share as a percentage number (0.0699 -> ``7``)."""
    return "n/a" if x is None else format(100.0 * float(x), fmt)


def likelihood_ratio(dchi2: float) -> str:
    """:math:`\\exp(\\Delta\\chi^2 / 2)` as text, in powers of ten where it would overflow a float."""
    half = float(dchi2) / 2.0
    return num(math.exp(half), ".3g") if half < 700.0 else f"1e{half / math.log(10.0):.0f}"


def short(classification: str | None) -> str:
    """A profile classification in a table cell's words."""
    return _SHORT.get(classification, classification or "-")


def ci_text(ci, fmt: str = ".3g") -> str:
    """A profile interval ``(lower, upper)``, each side ``open`` where it is None."""
    lo, hi = ci
    return f"[{num(lo, fmt) if lo is not None else 'open'}, {num(hi, fmt) if hi is not None else 'open'}]"


def names(items, empty: str = "none", sep: str = ", ") -> str:
    """Names joined, or ``empty`` for none."""
    items = list(items)
    return sep.join(str(i) for i in items) if items else empty


FILTERS = {"num": num, "pct": pct, "lr": likelihood_ratio, "short": short, "ci": ci_text, "names": names}

"""Box priors for the calibration parameters: uniform and log-uniform on ``[lower, upper]``.

The paper (Section 2.7, eq. 10-12) constrains the parameters to a box :math:`\\alpha_i^{\\min} <
\\alpha_i < \\alpha_i^{\\max}` (Table 1). A box is all it says, so we offer the two natural
densities on it:

* ``uniform``: the literal reading, :math:`p(x) = 1/(b - a)`;
* ``loguniform``: uniform in :math:`\\log x`, :math:`p(x) = 1 / (x \\log(b/a))`, the scale-invariant
  default for positive scale parameters (moduli and rates, which the box spans over several
  decades).

Each prior is a small frozen dataclass with ``logpdf``, ``cdf`` and ``ppf``, registered by name in
:data:`PRIORS` (the paper's parameters use ``PRIORS[spec.prior](lower, upper)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError, check_finite

__all__ = ["BoxPrior", "UniformPrior", "LogUniformPrior", "PRIORS", "make_prior"]


@dataclass(frozen=True)
class BoxPrior:
    """A proper density supported on ``[lower, upper]`` (``lower < upper``, both finite)."""

    lower: float
    upper: float

    def __post_init__(self):
        lo = check_finite("prior lower bound", self.lower)
        hi = check_finite("prior upper bound", self.upper)
        if not lo < hi:
            raise ValidationError(
                "prior bounds",
                (lo, hi),
                "lower < upper",
                "swap the two bounds if they are inverted",
            )

    def logpdf(self, x) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def cdf(self, x) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def ppf(self, q) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def sample(self, size, *, rng=None) -> np.ndarray:
        """Draw ``size`` values by inversion, :math:`x = F^{-1}(U)`, :math:`U \\sim U(0, 1)`."""
        rng = np.random.default_rng(rng)
        return self.ppf(rng.random(size))


@dataclass(frozen=True)
class UniformPrior(BoxPrior):
    """Uniform density on the box.

    .. math:: p(x) = \\frac{1}{b - a}, \\quad a \\le x \\le b.
    """

    def logpdf(self, x):
        x = np.asarray(x, dtype=float)
        inside = (x >= self.lower) & (x <= self.upper)
        return np.where(inside, -math.log(self.upper - self.lower), -np.inf)

    def cdf(self, x):
        x = np.asarray(x, dtype=float)
        return np.clip((x - self.lower) / (self.upper - self.lower), 0.0, 1.0)

    def ppf(self, q):
        return self.lower + np.asarray(q, dtype=float) * (self.upper - self.lower)


@dataclass(frozen=True)
class LogUniformPrior(BoxPrior):
    """Log-uniform (reciprocal) density on the box, ``0 < a < b``.

    .. math:: p(x) = \\frac{1}{x \\, \\log(b / a)}, \\quad a \\le x \\le b.
    """

    def __post_init__(self):
        super().__post_init__()
        if not self.lower > 0:
            raise ValidationError(
                "log-uniform prior lower bound",
                self.lower,
                "a number > 0",
                "use prior = 'uniform' for a parameter that can be zero or negative",
            )

    def logpdf(self, x):
        x = np.asarray(x, dtype=float)
        inside = (x >= self.lower) & (x <= self.upper)
        with np.errstate(divide="ignore", invalid="ignore"):
            val = -np.log(x) - math.log(math.log(self.upper / self.lower))
        return np.where(inside, val, -np.inf)

    def cdf(self, x):
        x = np.clip(np.asarray(x, dtype=float), self.lower, self.upper)
        return np.log(x / self.lower) / math.log(self.upper / self.lower)

    def ppf(self, q):
        q = np.asarray(q, dtype=float)
        return self.lower * np.exp(q * math.log(self.upper / self.lower))


#: Registered box priors, by the name used in
# :class:`~bayestissue.inference.parameters.ParameterSpec`.
PRIORS: dict[str, type[BoxPrior]] = {"uniform": UniformPrior, "loguniform": LogUniformPrior}


def make_prior(name: str, lower: float, upper: float) -> BoxPrior:
    """Return the registered prior ``name`` on ``[lower, upper]``.

    Raises
    ------
    ValidationError
        For an unknown prior name or invalid bounds.
    """
    if name not in PRIORS:
        raise ValidationError("prior", name, f"one of {sorted(PRIORS)}")
    return PRIORS[name](lower, upper)

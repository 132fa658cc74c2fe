"""Does another engine contradict the verdict? The marginal quantiles of two samples of one posterior, compared.

An ensemble sampler's verdict (R-hat between ensembles, ESS, length in autocorrelation times) cannot see a region
that no ensemble visited: when every ensemble cuts the same arm of a curved posterior, they agree with each other and
the verdict says CONVERGED (issue 36: on a staircase creep test the emcee ensembles put 5 % of the mass at
mu > 0.165 kPa, a nested run 27.5 %). A sample drawn another way (nested sampling from the prior, which needs no
start) is an independent check.

For every parameter the 5, 50 and 95 % quantiles :math:`q^a_{p}, q^b_{p}` of the two samples are mapped to the scaled
box coordinate :math:`u \\in [0, 1]` (the log scale of a log-uniform box: what the prior is uniform in) and compared
with the checked sample's 90 % width :math:`w = u(q^a_{95}) - u(q^a_{05})`. A quantile *differs* when both

.. math::

    \\frac{|u(q^a_p) - u(q^b_p)|}{w} > \\text{tol} \\quad\\text{and}\\quad
    \\frac{|q^a_p - q^b_p|}{\\sqrt{e_a^2 + e_b^2}} > z_\\text{min},

with :math:`e` each sample's own Monte Carlo error of that quantile (the ensembles' from their ESS, the nested runs'
from their bootstrap: :mod:`bayestissue.inference.evidence`). The defaults, tol = 0.1 and z_min = 4, keep both kinds
of false alarm small: a difference of a tenth of the interval is what a missed arm or mode produces (it moves a tail
quantile by a good part of the width) and is larger than the Monte Carlo error of a quantile at a few hundred
effective draws (about 0.03 w at ESS 500 for the 5 % quantile of a normal); 4 combined errors is a two-sided p of
6e-5 per quantity, so 30 quantities raise a false alarm about once in 500 checks. When the errors are
underestimated (the failure this is for), z only grows.

Which of the two is wrong the check cannot say: the ensembles may have missed a region no ensemble started in, or the
nested runs' bounds may have cut an arm (measured on the T1 mirror posterior: four nested runs of 1000 live points
all cut the arm with a stiffer matrix that the converged ensembles cover; README, Limitations). The text names the
wider sample as the likelier to be right (:meth:`EngineCheck.which`); either way the verdict is NOT CONVERGED.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue.inference.evidence import LEVELS  # the levels every Monte Carlo error in the package is for

__all__ = ["EngineCheck", "compare_quantiles", "compare_samples"]

#: Differing quantities named in the one-line text, largest first (cross_check.md has them all).
SHOWN = 4


@dataclass(frozen=True)
class EngineCheck:
    """Quantiles of a checked sample (``a``) and of an independent one (``b``), per parameter and level."""

    names: tuple[str, ...]
    q_a: np.ndarray  # (ndim, 3) natural units
    q_b: np.ndarray
    err: np.ndarray  # (ndim, 3) combined Monte Carlo error sqrt(e_a^2 + e_b^2)
    rel: np.ndarray  # (ndim, 3) |u_a - u_b| / (the checked sample's 90 % width in u)
    engine: str = "nested"
    other_verdict: str = ""
    time_s: float = 0.0
    tol: float = 0.1
    z_min: float = 4.0

    @property
    def z(self) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.abs(self.q_a - self.q_b) / self.err

    @property
    def differs(self) -> np.ndarray:
        """``(ndim, 3)`` bool: the quantile differs by more than tol of the width and more than z_min errors."""
        return (self.rel > self.tol) & ~(self.z <= self.z_min)

    @property
    def agree(self) -> bool:
        return not bool(np.any(self.differs))

    def text(self) -> str:
        """One sentence: agreement with the largest difference, or the quantities that differ."""
        worst = int(np.nanargmax(self.rel)) if np.any(np.isfinite(self.rel)) else 0
        j, k = divmod(worst, len(LEVELS))
        verdict = self.other_verdict.split(":")[0]
        own = f"; the {self.engine} runs' own verdict: {verdict} (cross_check.md)" if self.other_verdict else ""
        if self.agree:
            return (
                f"cross-checked by a {self.engine} run ({self.time_s:.0f} s): every 5/50/95 % quantile agrees "
                f"(largest difference {self.rel[j, k]:.3f} of the 90 % width, {self.names[j]} "
                f"{_level(k)}; limit {self.tol:g} and {self.z_min:g} Monte Carlo errors){own}"
            )
        flat = np.flatnonzero(self.differs)
        flat = flat[np.argsort(-self.rel.ravel()[flat], kind="stable")]
        parts = [
            f"{self.names[j]} {_level(k)} {self.q_a[j, k]:.4g} vs {self.q_b[j, k]:.4g} "
            f"({self.rel[j, k]:.2f} of the 90 % width, {self.z[j, k]:.1f} errors)"
            for j, k in (divmod(int(i), len(LEVELS)) for i in flat[:SHOWN])
        ]
        if flat.size > SHOWN:
            parts.append(f"{flat.size - SHOWN} more (cross_check.md)")
        return (
            f"a {self.engine} run of the same posterior disagrees ({self.time_s:.0f} s): " + "; ".join(parts) + " "
            f"(limit {self.tol:g} of the width and {self.z_min:g} Monte Carlo errors): one of the two missed part of "
            f"the posterior; {self.which()}{own}"
        )

    def which(self) -> str:
        """Which sample is the wider where they differ: the narrower one is the likelier to have missed mass (a
        heuristic: a sampler rarely invents mass where there is none, but either can miss some)."""
        rows = np.flatnonzero(self.differs.any(axis=1))
        ratio = (self.q_b[rows, 2] - self.q_b[rows, 0]) / np.maximum(self.q_a[rows, 2] - self.q_a[rows, 0], 1e-300)
        wider = [f"{self.names[j]} {r:.2f}" for j, r in zip(rows, ratio, strict=True)]
        if np.all(ratio > 1.0):
            side = f"the {self.engine} 90 % ranges are the wider (the ensembles' likelier to have missed a region)"
        elif np.all(ratio < 1.0):
            side = f"the {self.engine} 90 % ranges are the narrower (its runs' likelier to have cut an arm)"
        else:
            side = "neither sample is the wider everywhere"
        return f"{side}: {self.engine} / emcee 90 % width {', '.join(wider)}"

    def markdown(self) -> str:
        """The comparison as a table, one row per parameter."""
        head = [
            f"# Cross-check of the emcee sample by a {self.engine} run\n",
            f"{self.text()}.\n",
            "Quantiles 5 % / median / 95 %; difference in the scaled box coordinate over the emcee 90 % width, and in "
            "combined Monte Carlo errors (bayestissue.inference.engine_check).\n",
            f"| parameter | emcee | {self.engine} | largest difference / width | errors | |",
            "|---|---|---|---|---|---|",
        ]
        if self.other_verdict:
            head.insert(2, f"The {self.engine} runs' own verdict: {self.other_verdict}\n")
        rows = []
        for j, name in enumerate(self.names):
            k = int(np.argmax(self.rel[j]))
            fmt = " / ".join
            rows.append(
                f"| {name} | {fmt(f'{v:.4g}' for v in self.q_a[j])} | {fmt(f'{v:.4g}' for v in self.q_b[j])} | "
                f"{self.rel[j, k]:.3f} ({_level(k)}) | {self.z[j, k]:.1f} | "
                f"{'DIFFERS' if self.differs[j].any() else ''} |"
            )
        return "\n".join(head + rows) + "\n"


def _level(k: int) -> str:
    return ("5 %", "median", "95 %")[k]


def compare_samples(
    names, draws_a, err_a, draws_b, err_b, to_unit, *, engine: str = "nested", tol: float = 0.1, z_min: float = 4.0,
    other_verdict: str = "", time_s: float = 0.0,
) -> EngineCheck:  # fmt: skip
    """Compare two samples ``(n, ndim)`` of one posterior (module docstring): :func:`compare_quantiles` of their
    5/50/95 % quantiles.

    Parameters
    ----------
    names : the ``ndim`` parameter names (columns of both samples).
    draws_a, draws_b : equal-weight draws in natural units; ``a`` is the checked sample.
    err_a, err_b : ``(ndim, 3)`` Monte Carlo errors of each sample's 5/50/95 % quantiles.
    to_unit : map ``(n, ndim)`` natural values -> scaled box coordinate in [0, 1].
    """
    q_a = np.quantile(np.asarray(draws_a, dtype=float), LEVELS, axis=0).T
    q_b = np.quantile(np.asarray(draws_b, dtype=float), LEVELS, axis=0).T
    return compare_quantiles(names, q_a, err_a, q_b, err_b, to_unit, engine=engine, tol=tol, z_min=z_min,
                             other_verdict=other_verdict, time_s=time_s)  # fmt: skip


def compare_quantiles(
    names, q_a, err_a, q_b, err_b, to_unit, *, engine: str = "nested", tol: float = 0.1, z_min: float = 4.0,
    other_verdict: str = "", time_s: float = 0.0,
) -> EngineCheck:  # fmt: skip
    """Compare two estimates ``(ndim, 3)`` of one posterior's 5/50/95 % quantiles in natural units, with their
    Monte Carlo errors ``err_a``, ``err_b`` (module docstring; e.g. nested runs' weighted quantiles, which need no
    equal-weight draws). ``a`` is the checked estimate; ``to_unit`` as in :func:`compare_samples`."""
    q_a, q_b = np.asarray(q_a, dtype=float), np.asarray(q_b, dtype=float)
    u_a, u_b = to_unit(q_a.T).T, to_unit(q_b.T).T
    width = np.maximum(u_a[:, 2] - u_a[:, 0], 1e-12)
    rel = np.abs(u_a - u_b) / width[:, None]
    err = np.hypot(np.asarray(err_a, dtype=float), np.asarray(err_b, dtype=float))
    return EngineCheck(tuple(names), q_a, q_b, err, rel, engine, other_verdict, time_s, tol, z_min)

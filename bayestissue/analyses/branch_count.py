r"""How many relaxing branches a stress relaxation supports, by the evidence: the synthetic tendon (issue 32).

The tendon preset (an exponential fibre with dispersion and a recruitment stretch, a Prony series of :math:`N`
branches, :mod:`~bayestissue.mechanics.laws.prony`) is fitted with :math:`N` = 1, 2 and 3 to one ramp-and-hold
relaxation generated with two branches (``data/synthetic/tendon_relaxation.csv``, studies/make_tendon_example.py:
relaxation times 2 and 30 s, a toe, 161 samples over 180 s, noise sd 5 mN). Each count is one configuration of
``examples/`` (:data:`CONFIGS`: the settings a user would run; every further branch's viscous fraction fixed at
0.75, since with it free the likelihood has a flat direction, :mod:`~bayestissue.analyses.branch_ridges`, and the
recruitment stretch's box cut to [1.0, 1.04] so that no prior mass sits on the unrecruited plateau) run by ``fit``'s own
workflow (:func:`~bayestissue.workflows.run_calibration`: least squares, then the nested engine, nautilus, 4 runs of
500 live points, the noise sd integrated out). The log Bayes factor of count :math:`a` over :math:`b` is

.. math:: \ln B_{ab} = \ln\hat Z_a - \ln\hat Z_b, \qquad \sigma = \sqrt{\sigma_a^2 + \sigma_b^2},

each :math:`\sigma` the merged runs' error, and the evidence picks a count when it is the largest and every factor
over another count decides (:meth:`BranchCountRecord.decides`): by
:func:`~bayestissue.analyses.verdicts.evidence_decides` where both counts' runs agree on their evidence and the grade
is at least positive, or, where the other count's runs disagree (an over-parametrised count's posterior is
multimodal: which branch takes the extra mode), by
:func:`~bayestissue.analyses.verdicts.evidence_rejects_scattered`, against its highest run plus two sds of its runs.

The record also holds each count's posterior predictive band and its fit check (noise ratio, residual lag-1), so
that a count the evidence rejects can be seen not to fit.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from bayestissue.analyses.model_choice import NOT_NESTED, SOURCES, ModelEvidence
from bayestissue.analyses.verdicts import (
    evidence_decides,
    evidence_rejects_scattered,
    evidence_strength,
    scattered_upper,
)
from bayestissue.io.results import hash_sources

__all__ = [
    "BRANCHES",
    "CONFIGS",
    "DATA",
    "DATA_CSV",
    "QUICK",
    "SCATTER_RULE",
    "TRUE_BRANCHES",
    "BranchCountRecord",
    "BranchFit",
    "count_hash",
]

#: The branch counts the stage compares, and the count that generated the data.
BRANCHES = (1, 2, 3)
TRUE_BRANCHES = 2
#: Per count, the experiment file (in ``data/synthetic/``: the same CSV, the tissue with that many branches) and the
#: configuration (in ``examples/``).
DATA = {1: "tendon_relaxation_one_branch.toml", 2: "tendon_relaxation.toml", 3: "tendon_relaxation_three_branches.toml"}
CONFIGS = {1: "tendon_one_branch.toml", 2: "tendon_relaxation.toml", 3: "tendon_three_branches.toml"}
#: :meth:`BranchCountRecord.decides`'s name of the rule that rejects a count whose runs disagree.
SCATTER_RULE = "highest run + 2 sd"
#: The data every count fits.
DATA_CSV = "tendon_relaxation.csv"
#: ``--quick``: the nested settings replaced (a capped smoke run of the same code; its numbers mean nothing) and the
#: counts run.
QUICK = {
    "nested": {"n_live": 100, "n_eff": 100, "n_runs": 2, "max_evaluations": 3000},
    "n_starts": 1,
    "branches": (1, 2),
}


def count_hash(mode: str, root: Path, n: int) -> str:
    """SHA-256 (first 16 hex digits) of what count ``n``'s numbers depend on: the package sources of
    :data:`~bayestissue.analyses.model_choice.SOURCES` (but :data:`~bayestissue.analyses.model_choice.NOT_NESTED`),
    the experiment file and its CSV, the configuration and, under ``--quick``, its replaced settings."""
    h = hash_sources(hashlib.sha256(), SOURCES, exclude=NOT_NESTED)
    data = root / "data" / "synthetic"
    for f in (data / DATA[n], data / DATA_CSV, root / "examples" / CONFIGS[n]):
        h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    h.update(repr((mode, QUICK if mode == "quick" else None)).encode())
    return h.hexdigest()[:16]


@dataclass(frozen=True)
class BranchFit:
    """One branch count's calibration: its nested runs (``evidence``), its fit check (``noise_ratio`` the posterior
    noise sd over the data's own estimate, ``lag1`` the residuals' lag-1 autocorrelation, ``fits`` the rule of
    :func:`~bayestissue.inference.fit_check.fit_check`) and its posterior predictive on the record's thinned time
    grid: ``median``, ``lower``, ``upper`` the model curve's 50 / 5 / 95 % and ``band`` the 5 / 95 % of the model
    plus noise (mN). ``terms``: the tissue terms of its posterior (:mod:`~bayestissue.workflows.tissue_terms`:
    moduli, relaxation at full hold, each branch's relaxation time), quantity -> (5 %, median, 95 %), and their
    ``units``."""

    branches: int
    evidence: ModelEvidence
    noise_ratio: float
    lag1: float
    fits: bool
    fit_check: str
    median: list[float]
    lower: list[float]
    upper: list[float]
    band: tuple[list[float], list[float]]
    terms: dict[str, tuple[float, float, float]]
    units: dict[str, str]


@dataclass(frozen=True)
class BranchCountRecord:
    """The branch-count stage's record: ``fits`` by count (as a string key), the data on the thinned grid
    (``time_s``, ``force_mN``; every ``thin``-th sample), the generating count, and the tissue terms of the
    generating values (``truth_terms``, quantity -> value)."""

    SCHEMA: ClassVar[str] = "bayestissue.branch_count"
    VERSION: ClassVar[int] = 2
    mode: str
    true_branches: int
    thin: int
    time_s: list[float]
    force_mN: list[float]
    fits: dict[str, BranchFit]
    truth_terms: dict[str, float]

    @property
    def counts(self) -> list[int]:
        return sorted(int(k) for k in self.fits)

    def log_z(self, n: int) -> tuple[float, float]:
        """Count ``n``'s merged (log Z, error)."""
        return tuple(self.fits[str(n)].evidence.merged)

    def log_bayes(self, a: int, b: int) -> tuple[float, float]:
        """:math:`\\ln B` of count ``a`` over ``b`` and its error (module docstring)."""
        (za, ea), (zb, eb) = self.log_z(a), self.log_z(b)
        return float(za - zb), float(np.hypot(ea, eb))

    @property
    def best(self) -> int:
        """The count with the largest merged log Z."""
        return max(self.counts, key=lambda n: self.log_z(n)[0])

    def decides(self, n: int) -> tuple[bool, str]:
        """Whether the best count's factor over count ``n`` decides, and by which rule: ``"runs agree"``
        (:func:`~bayestissue.analyses.verdicts.evidence_decides`, both counts' runs agree), ``"highest run + 2 sd"``
        (:func:`~bayestissue.analyses.verdicts.evidence_rejects_scattered`: ``n``'s runs disagree and even their
        highest plus two of their sds lies a positive grade below), or why not."""
        a, b = self.fits[str(self.best)].evidence, self.fits[str(n)].evidence
        if a.runs_agree and b.runs_agree:
            ok = evidence_decides(*self.log_bayes(self.best, n), True)
            return ok, "runs agree" if ok else "not graded positive"
        if not a.runs_agree:
            return False, f"the {self.best}-branch runs disagree"
        ok = evidence_rejects_scattered(tuple(a.merged), True, b.log_z, b.runs_ok)
        return ok, SCATTER_RULE if ok else f"the {n}-branch runs disagree"

    def scatter_bound(self, n: int) -> float:
        """ln B of the best count over count ``n``'s highest run plus two sds of its runs (the bound of
        :func:`~bayestissue.analyses.verdicts.evidence_rejects_scattered`)."""
        return float(self.log_z(self.best)[0] - scattered_upper(self.fits[str(n)].evidence.log_z))

    @property
    def chosen(self) -> int | None:
        """The count the evidence picks, or None where the best count's factor over another does not decide
        (:meth:`decides`)."""
        others = [n for n in self.counts if n != self.best]
        return self.best if others and all(self.decides(n)[0] for n in others) else None

    @property
    def term_names(self) -> list[str]:
        """Every tissue term of any count, in the counts' order."""
        return list(dict.fromkeys(q for n in self.counts for q in self.fits[str(n)].terms))

    def unit(self, term: str) -> str:
        """The unit of tissue term ``term`` (from the first count that has it)."""
        return next(self.fits[str(n)].units[term] for n in self.counts if term in self.fits[str(n)].units)

    def recovered(self, n: int) -> dict[str, bool]:
        """Per tissue term that count ``n`` and the generating model share: whether its 90 % interval holds the
        generating value."""
        terms = self.fits[str(n)].terms
        return {q: bool(terms[q][0] <= v <= terms[q][2]) for q, v in self.truth_terms.items() if q in terms}

    def grades(self) -> dict[int, tuple[float, float, str]]:
        """Per other count: (ln B of the best over it, error, grade)."""
        best = self.best
        out = {}
        for n in self.counts:
            if n != best:
                b, e = self.log_bayes(best, n)
                out[n] = (b, e, evidence_strength(b, e))
        return out

"""Parameter specifications, the box, and the map to an unconstrained sampling space with its
log-Jacobian.

Every sampled parameter :math:`x \\in [a, b]` is mapped to :math:`z \\in \\mathbb{R}` through the
box scaled to :math:`[0, 1]` (linearly, or in :math:`\\log x` for ``scale="log"``) followed by the
logit:

.. math::

    u = \\frac{g(x) - g(a)}{g(b) - g(a)}, \\qquad z = \\operatorname{logit} u = \\log\\frac{u}{1 -
    u},
    \\qquad g(x) = x \\text{ or } \\log x .

The sampler works in :math:`z`, so the target density there carries the log-Jacobian of the inverse
map

.. math::

    \\log\\left|\\frac{dx}{dz}\\right| = \\log \\sigma(z) + \\log \\sigma(-z) + \\log(g(b) - g(a))
    + [\\text{scale} = \\log]\\, \\log x,

with :math:`\\sigma` the logistic function. Forgetting it ("the classic Jacobian mistake") samples
the wrong prior; ``tests/inference/test_priors_parameters.py`` catches it with a KS test on draws from the
sampler's own path.

The scaling is also the paper's (Section 2.7.1): the least-squares warm start scales each parameter
by its initial guess, :math:`s_i = \\alpha_i^0`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from scipy.special import expit, log_expit, logit

from bayestissue._validation import ValidationError, check_finite
from bayestissue.inference.ordering import (
    OrderedGroup,
    canonical,
    groups_in_force,
    in_order,
    order_index,
    order_statistics,
    relabelling,
    sort_keys,
)
from bayestissue.inference.priors import PRIORS, BoxPrior, make_prior

__all__ = ["ParameterSpec", "ParameterSet", "SCALES"]

#: Scalings of the box before the logit: ``linear`` (g(x) = x) or ``log`` (g(x) = log x, needs lower
# > 0).
SCALES = ("linear", "log")


@dataclass(frozen=True)
class ParameterSpec:
    """One parameter: name, unit, box, prior, and whether it is sampled or held fixed.

    Parameters
    ----------
    name : str
        Identifier (``mu``, ``ginf2``, ``sigma_T1`` ...).
    unit : str
        Unit string (``kPa``, ``1/s``, ``1``, ``mm``).
    lower, upper : float
        The box :math:`[a, b]` (paper Table 1 by default), ``lower < upper``.
    prior : {"uniform", "loguniform"}
        Density on the box (see :mod:`bayestissue.inference.priors`).
    scale : {"linear", "log"} or None
        Scaling of the box before the logit; ``None`` picks ``log`` for log-uniform priors, else
        ``linear``.
    value : float or None
        Initial guess (sampled) or the held value (fixed); must lie in the box.
    fixed : bool
        Hold the parameter at ``value`` instead of sampling it.
    tied_to : str or None
        Name of another parameter of the same set whose value this one takes (neither sampled nor
        held): e.g. ``ginf3`` tied to ``ginf2`` makes fibre families 2 and 3 share a parameter.
    """

    name: str
    unit: str
    lower: float
    upper: float
    prior: str = "uniform"
    scale: str | None = None
    value: float | None = None
    fixed: bool = False
    tied_to: str | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ValidationError("parameter name", self.name, "a Python identifier such as 'mu'")
        lo = check_finite(f"{self.name} lower bound", self.lower)
        hi = check_finite(f"{self.name} upper bound", self.upper)
        if not lo < hi:
            raise ValidationError(f"{self.name} bounds", [lo, hi], "lower < upper", "the bounds look inverted")
        if self.prior not in PRIORS:
            raise ValidationError(f"{self.name} prior", self.prior, f"one of {sorted(PRIORS)}")
        scale = self.scale or ("log" if self.prior == "loguniform" else "linear")
        if scale not in SCALES:
            raise ValidationError(f"{self.name} scale", self.scale, f"one of {list(SCALES)}")
        if (scale == "log" or self.prior == "loguniform") and lo <= 0:
            raise ValidationError(f"{self.name} lower bound", lo, "a number > 0 for a log-uniform prior or log scale")
        object.__setattr__(self, "scale", scale)
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)
        if self.value is not None:
            v = check_finite(f"{self.name} value", self.value)
            if not lo <= v <= hi:
                raise ValidationError(f"{self.name} initial/fixed value", v, f"a value inside the box [{lo}, {hi}]")
            object.__setattr__(self, "value", v)
        elif self.fixed:
            raise ValidationError(f"{self.name} value", None, "a value for a fixed parameter")
        if self.tied_to is not None:
            if self.fixed:
                raise ValidationError(f"{self.name}", "fixed and tied", "either fixed or tied, not both")
            if self.tied_to == self.name:
                raise ValidationError(f"{self.name} tied_to", self.tied_to, "the name of another parameter")

    @property
    def prior_dist(self) -> BoxPrior:
        """The prior as a :class:`~bayestissue.inference.priors.BoxPrior` object."""
        return make_prior(self.prior, self.lower, self.upper)


@dataclass(frozen=True)
class ParameterSet:
    """An ordered collection of :class:`ParameterSpec` with the transforms used by the sampler.

    ``theta`` always means the *sampled* parameters in their natural units, shape ``(n_sets,
    n_sampled)`` (or ``(n_sampled,)``); :meth:`expand` inserts the fixed values to give the full
    vector in the order of :attr:`specs`. ``fixed_inputs`` records inputs that are not parameters
    (volume fractions, fibre directions, K, eps0 ...) for the provenance of the results. ``ordered`` holds the
    label-switching groups (:class:`OrderedGroup`) whose prior is restricted to one labelling; a group applies to its
    sampled terms (a term with a fixed or tied parameter leaves it), and only while their keys (and, for an
    exchangeable group, every parameter of a term) have the same box and prior: a group that loses that, or keeps
    fewer than two terms, is dropped (:attr:`ordered` then lists only the groups in force).
    """

    specs: tuple[ParameterSpec, ...]
    fixed_inputs: Mapping = field(default_factory=dict)
    ordered: tuple[OrderedGroup, ...] = ()

    def __post_init__(self):
        specs = tuple(self.specs)
        if not specs or not all(isinstance(s, ParameterSpec) for s in specs):
            raise ValidationError("parameters", specs, "a non-empty sequence of ParameterSpec")
        names = [s.name for s in specs]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValidationError("parameter names", names, "unique names", f"duplicated: {dup}")
        by_name = {s.name: s for s in specs}
        for s in specs:
            if s.tied_to is None:
                continue
            target = by_name.get(s.tied_to)
            if target is None or target.tied_to is not None:
                raise ValidationError(
                    f"{s.name} tied_to", s.tied_to, f"an untied parameter among {[n for n in names if n != s.name]}"
                )
            if target.unit != s.unit:
                raise ValidationError(f"{s.name} tied_to", s.tied_to, f"a parameter in the same unit ({s.unit})")
        object.__setattr__(self, "specs", specs)
        object.__setattr__(self, "fixed_inputs", dict(self.fixed_inputs))
        object.__setattr__(self, "ordered", groups_in_force(self.ordered, by_name))

    # ---- bookkeeping
    # -------------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """All parameter names, sampled and fixed, in order."""
        return tuple(s.name for s in self.specs)

    @cached_property
    def sampled(self) -> tuple[ParameterSpec, ...]:
        return tuple(s for s in self.specs if not s.fixed and s.tied_to is None)

    @property
    def sampled_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.sampled)

    @property
    def tied(self) -> dict[str, str]:
        """Tied parameters: name -> the name whose value it takes."""
        return {s.name: s.tied_to for s in self.specs if s.tied_to is not None}

    @property
    def tied_text(self) -> str:
        """The ties as ``"ginf3=ginf2, gamma3=gamma2"`` (``"none"`` without ties), for provenance."""
        return ", ".join(f"{a}={b}" for a, b in self.tied.items()) or "none"

    @property
    def n_sampled(self) -> int:
        return len(self.sampled)

    @property
    def ordered_text(self) -> str:
        """The orderings in force as ``"alpha1 > alpha2; beta1 > beta1_2"`` (``"none"``), for provenance."""
        return "; ".join(g.text for g in self.ordered) or "none"

    @cached_property
    def _order_index(self) -> tuple[tuple[np.ndarray, np.ndarray | None], ...]:
        return order_index(self.ordered, self.sampled_names)

    @cached_property
    def _lo(self) -> np.ndarray:
        return np.array([s.lower for s in self.sampled])

    @cached_property
    def _hi(self) -> np.ndarray:
        return np.array([s.upper for s in self.sampled])

    @property
    def lower(self) -> np.ndarray:
        """Lower bounds of the sampled parameters."""
        return self._lo.copy()

    @property
    def upper(self) -> np.ndarray:
        """Upper bounds of the sampled parameters."""
        return self._hi.copy()

    @cached_property
    def _prior_consts(self) -> tuple[np.ndarray, np.ndarray]:
        """(is_loguniform, log-normalising constant) per sampled parameter."""
        is_lu = np.array([s.prior == "loguniform" for s in self.sampled])
        const = np.array(
            [
                -math.log(math.log(s.upper / s.lower)) if s.prior == "loguniform" else -math.log(s.upper - s.lower)
                for s in self.sampled
            ]
        )
        return is_lu, const

    @property
    def initial(self) -> np.ndarray:
        """Initial guess of the sampled parameters (box centre in the scaled space where none is
        given)."""
        u_mid = np.full(self.n_sampled, 0.5)
        mid = self._from_unit(u_mid)
        return np.array([s.value if s.value is not None else m for s, m in zip(self.sampled, mid, strict=False)])

    def index(self, name: str) -> int:
        """Position of ``name`` among the sampled parameters."""
        names = self.sampled_names
        if name not in names:
            raise ValidationError("parameter name", name, f"one of the sampled parameters {names}")
        return names.index(name)

    def updated(
        self,
        *,
        fixed: Mapping[str, float] | Iterable[str] | None = None,
        sampled: Iterable[str] | None = None,
        bounds: Mapping[str, Sequence[float]] | None = None,
        priors: Mapping[str, str] | None = None,
        initial: Mapping[str, float] | None = None,
        fixed_inputs: Mapping | None = None,
        tied: Mapping[str, str] | None = None,
    ) -> ParameterSet:
        """Return a copy with some parameters fixed, freed, tied, re-bounded, re-priored or
        re-initialised.

        Parameters
        ----------
        fixed : mapping name -> value, or names (held at their current ``value``).
        sampled : names to sample (a parameter cannot be both in ``fixed`` and ``sampled``).
        bounds : mapping name -> ``(lower, upper)``.
        priors : mapping name -> prior name.
        initial : mapping name -> initial value.
        fixed_inputs : entries merged into :attr:`fixed_inputs`.
        tied : mapping name -> name of the parameter whose value it takes (see
            :attr:`ParameterSpec.tied_to`).

        Raises
        ------
        ValidationError
            For unknown names, a name both fixed and sampled (or tied), inverted bounds or a value
            outside the box.
        """
        known = set(self.names)
        fixed_map = dict(fixed) if isinstance(fixed, Mapping) else {n: None for n in (fixed or ())}
        sampled = list(sampled or ())
        for label, names in (
            ("fixed", fixed_map),
            ("sampled", sampled),
            ("bounds", bounds or {}),
            ("priors", priors or {}),
            ("initial", initial or {}),
            ("tied", tied or {}),
            ("tied-to", list((tied or {}).values())),
        ):
            unknown = sorted(set(names) - known)
            if unknown:
                raise ValidationError(f"{label} parameter names", unknown, f"names among {list(self.names)}")
        both = sorted(set(fixed_map) & set(sampled))
        if both:
            raise ValidationError("parameters", both, "each parameter either fixed or sampled, not both")
        both = sorted(set(tied or {}) & (set(fixed_map) | set(sampled)))
        if both:
            raise ValidationError("parameters", both, "each parameter either tied, fixed or sampled")
        new = []
        for s in self.specs:
            kw = {}
            if s.name in (bounds or {}):
                b = tuple(bounds[s.name])
                if len(b) != 2:
                    raise ValidationError(f"{s.name} bounds", b, "a pair [lower, upper]")
                kw.update(lower=b[0], upper=b[1])
            if s.name in (priors or {}):
                kw["prior"] = priors[s.name]
                if priors[s.name] == "loguniform":
                    kw["scale"] = "log"
            if s.name in (initial or {}):
                kw["value"] = initial[s.name]
            if s.name in fixed_map:
                kw["fixed"] = True
                if fixed_map[s.name] is not None:
                    kw["value"] = fixed_map[s.name]
            if s.name in sampled:
                kw.update(fixed=False, tied_to=None)
            if s.name in (tied or {}):
                kw.update(fixed=False, tied_to=tied[s.name])
            new.append(replace(s, **kw) if kw else s)
        inputs = dict(self.fixed_inputs)
        inputs.update(fixed_inputs or {})
        return ParameterSet(tuple(new), inputs, self.ordered)

    # ---- vectors
    # -----------------------------------------------------------------------------------
    def _check_theta(self, theta) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        if theta.shape[-1:] != (self.n_sampled,) or theta.ndim > 2:
            raise ValidationError("theta", f"array of shape {theta.shape}", f"shape (n_sets, {self.n_sampled})")
        return theta

    @cached_property
    def expand_matrix(self) -> np.ndarray:
        """``(n_total, n_sampled)``: the derivative of :meth:`expand` (1 where a parameter is the sampled one or tied
        to it, else 0), so that ``d/dtheta f(expand(theta)) = f'(x) @ expand_matrix``."""
        n = self.n_sampled
        return (self.expand(np.eye(n)) - self.expand(np.zeros(n))).T

    def expand(self, theta) -> np.ndarray:
        """Insert the fixed values: ``(..., n_sampled) -> (..., n_total)`` in the order of
        :attr:`specs`."""
        theta = self._check_theta(theta)
        out = np.empty(theta.shape[:-1] + (len(self.specs),))
        j = 0
        for i, s in enumerate(self.specs):
            if s.fixed:
                out[..., i] = s.value
            elif s.tied_to is None:
                out[..., i] = theta[..., j]
                j += 1
        for i, s in enumerate(self.specs):
            if s.tied_to is not None:
                out[..., i] = out[..., self.names.index(s.tied_to)]
        return out

    @cached_property
    def _gcache(self):
        is_log = np.array([s.scale == "log" for s in self.sampled])
        lo, hi = self._lo, self._hi
        ga = np.where(is_log, np.log(np.where(is_log, lo, 1.0)), lo)
        gb = np.where(is_log, np.log(np.where(is_log, hi, 1.0)), hi)
        return is_log, ga, gb

    def _g(self):
        """Per sampled parameter: (is_log, g(a), g(b))."""
        return self._gcache

    def _to_unit(self, theta) -> np.ndarray:
        is_log, ga, gb = self._g()
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.where(is_log, np.log(np.where(is_log, theta, 1.0)), theta)
        return (g - ga) / (gb - ga)

    def _from_unit(self, u) -> np.ndarray:
        is_log, ga, gb = self._g()
        g = ga + np.asarray(u, dtype=float) * (gb - ga)
        x = np.where(is_log, np.exp(np.where(is_log, g, 0.0)), g)
        return np.clip(x, self._lo, self._hi)

    def to_unit(self, theta) -> np.ndarray:
        """Scaled box coordinates :math:`u \\in [0, 1]` (linear or log scale per parameter)."""
        return self._to_unit(self._check_theta(theta))

    def from_unit(self, u) -> np.ndarray:
        """Inverse of :meth:`to_unit`."""
        return self._from_unit(self._check_theta(u))

    def to_unconstrained(self, theta) -> np.ndarray:
        """:math:`z = \\operatorname{logit} u(x)`; points on the bounds map to
        :math:`\\pm\\infty`."""
        u = self.to_unit(theta)
        with np.errstate(divide="ignore"):
            return logit(u)

    def from_unconstrained(self, z) -> np.ndarray:
        """:math:`x = g^{-1}(g(a) + \\sigma(z) (g(b) - g(a)))`."""
        return self._from_unit(expit(self._check_theta(z)))

    def log_abs_det_jacobian_terms(self, z) -> np.ndarray:
        """:math:`\\log|dx_i/dz_i|` per parameter at ``z``; shape ``z.shape``."""
        z = self._check_theta(z)
        is_log, ga, gb = self._g()
        x = self.from_unconstrained(z)
        terms = log_expit(z) + log_expit(-z) + np.log(gb - ga)
        return terms + np.where(is_log, np.log(np.where(is_log, x, 1.0)), 0.0)

    def log_abs_det_jacobian(self, z) -> np.ndarray:
        """:math:`\\sum_i \\log|dx_i/dz_i|` at ``z``; shape ``z.shape[:-1]``."""
        return self.log_abs_det_jacobian_terms(z).sum(axis=-1)

    def log_prior(self, theta) -> np.ndarray:
        """Sum of the prior log-densities of the sampled parameters; ``-inf`` outside the box."""
        theta = self._check_theta(theta)
        is_lu, const = self._prior_consts
        inside = np.all((theta >= self._lo) & (theta <= self._hi), axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            logx = np.log(np.where(is_lu, np.abs(theta), 1.0))
        total = np.sum(const - np.where(is_lu, logx, 0.0), axis=-1)
        if self._order_index:  # one labelling, density n! there (OrderedGroup); nothing to do on the paper's model
            inside &= in_order(theta, self._order_index)
            total = total + sum(math.lgamma(keys.size + 1) for keys, _ in self._order_index)
        return np.where(inside, total, -np.inf)

    def in_order(self, theta) -> np.ndarray:
        """Whether the keys of every ordered group decrease strictly (:class:`OrderedGroup`); ``theta.shape[:-1]``."""
        return in_order(self._check_theta(theta), self._order_index)

    def from_prior_quantiles(self, q) -> np.ndarray:
        """The prior transform of nested sampling: :math:`x_i = F_i^{-1}(q_i)`, ``q`` ``(..., n_sampled)`` in
        :math:`[0, 1]`, with :math:`F_i` the CDF of parameter :math:`i`'s box prior (uniform: :math:`a + q(b - a)`;
        log-uniform: :math:`a (b/a)^q`). Uniform ``q`` gives exact prior draws; this is the prior that
        :meth:`log_prior` evaluates, whatever the parameter's ``scale``.

        The keys of an ordered group (:class:`OrderedGroup`) go through the order statistics of ``n`` uniforms first,
        a bijection of the unit cube onto the ordered region: :math:`v_1 = q_1^{1/n}`, :math:`v_k = v_{k-1}
        q_k^{1/(n-k+1)}` (the largest of ``n`` uniforms has CDF :math:`v^n`; given it, the rest are ``n - 1``
        uniforms below it), so that the nested sampler sees one labelling, not ``n!`` copies of each mode."""
        q = order_statistics(self._check_theta(q), self._order_index)
        is_lu, _ = self._prior_consts
        lo, hi = self._lo, self._hi
        with np.errstate(divide="ignore", invalid="ignore"):
            log_ratio = np.log(np.where(is_lu, hi / np.where(is_lu, lo, 1.0), 1.0))
        x = np.where(is_lu, lo * np.exp(q * log_ratio), lo + q * (hi - lo))
        return np.clip(x, lo, hi)

    def sample_prior(self, n: int, *, rng=None) -> np.ndarray:
        """``n`` independent prior draws of the sampled parameters, shape ``(n, n_sampled)``."""
        rng = np.random.default_rng(rng)
        draws = np.column_stack([s.prior_dist.sample(n, rng=rng) for s in self.sampled])
        return sort_keys(draws, self._order_index)

    def relabelling(self, theta) -> np.ndarray:
        """The positions ``perm`` with ``canonical(theta) == theta[perm]`` for one point ``theta`` (n_sampled,): how
        to carry quantities attached to each parameter (intervals, flags) into the ordered labelling."""
        return relabelling(self._check_theta(theta), self._order_index)

    def canonical(self, theta) -> np.ndarray:
        """``theta`` relabelled into the ordered region: the terms of each exchangeable group permuted so that their
        keys decrease (a point of another labelling has the same likelihood); other groups are left as they are."""
        return canonical(self._check_theta(theta), self._order_index)

    def describe(self) -> list[dict]:
        """One dict per parameter (name, unit, bounds, prior, scale, value, fixed) for
        provenance."""
        return [
            {
                "name": s.name,
                "unit": s.unit,
                "lower": s.lower,
                "upper": s.upper,
                "prior": s.prior,
                "scale": s.scale,
                "value": math.nan if s.value is None else s.value,
                "fixed": s.fixed,
                "tied_to": s.tied_to or "",
            }
            for s in self.specs
        ]

r"""Forward models of experiments as the inference layer sees them: callables ``(n_sets, p) -> (n_sets, n_obs)``.

A plain experiment's forward is :class:`bayestissue.mechanics.ForwardModel` itself (fixed inputs computed once).
This module adds what the studies need beyond the material parameters:

* :class:`SpecimenForward` -- one experiment under *specimen-level* parameters appended to the material
  parameters (one kind, or ``"angle+scale"`` for both): ``"scale"`` multiplies every modulus (the parameters of
  role ``modulus``: mu, kappa, ginf_k for the paper's laws) of that specimen by :math:`s` (a stiffer or softer
  piece of the sole, cause 3 of the paper), ``"angle"`` sets the in-plane half-angle :math:`\alpha` (degrees) of
  fibre families 2 and 3, :math:`v_{2,3} = (\cos\alpha, \pm\sin\alpha, 0)` (the paper's directions have
  :math:`\alpha = 20.05^\circ`; cause 2).
* :class:`ExperimentResiduals` -- stacked scaled residuals :math:`(y_{obs} - u(\theta))/\sigma` of one or several
  experiments, for profile likelihoods and scaled sensitivities.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.inference import ParameterSpec
from bayestissue.mechanics import Experiment, ForwardModel, TissueConfig, param_names
from bayestissue.paper import MIRROR_TIES, PAPER_HALF_ANGLE_DEG

__all__ = [
    "SpecimenForward",
    "ExperimentResiduals",
    "MirrorResiduals",
    "MIRROR_NAMES",
    "SPECIMEN_KINDS",
    "specimen_kinds",
    "specimen_spec",
    "tissue_with_half_angle",
    "noise_sd",
]


def noise_sd(experiment: Experiment, default: float | None = None) -> float:
    """The experiment's noise sd (mm) from its data file header, else ``default``; raise if neither."""
    sd = experiment.noise_sd_mm if experiment.noise_sd_mm is not None else default
    if sd is None:
        raise ValidationError(
            f"experiment {experiment.name} noise_sd_mm",
            None,
            "a noise sd in the data file header",
            "or pass a default",
        )
    return check_positive("noise_sd_mm", sd)


def tissue_with_half_angle(tissue: TissueConfig, alpha_deg: float) -> TissueConfig:
    """``tissue`` with fibre families 2 and 3 (and their second branches, if any) at
    :math:`(\\cos\\alpha, \\pm\\sin\\alpha, 0)`."""
    a = np.radians(float(alpha_deg))
    d = np.array(tissue.directions, dtype=float)
    if d.shape[0] - len(tissue.second_branch) != 3:
        raise ValidationError("tissue.directions", d.shape, "three fibre families")
    d[1] = (np.cos(a), np.sin(a), 0.0)
    d[2] = (np.cos(a), -np.sin(a), 0.0)
    for j, k in enumerate(tissue.second_branch):
        d[3 + j] = d[k - 1]
    return replace(tissue, directions=d)


#: Kinds of specimen-level parameter.
SPECIMEN_KINDS = ("scale", "angle")


def specimen_kinds(kind: str | None) -> tuple[str, ...]:
    """``"scale"``, ``"angle"`` or several joined by ``+`` (e.g. ``"angle+scale"``: both, in that order)."""
    kinds = tuple(kind.split("+")) if kind else ()
    if any(k not in SPECIMEN_KINDS for k in kinds) or len(set(kinds)) != len(kinds):
        raise ValidationError("specimen parameter kind", kind, "'scale', 'angle' or 'angle+scale'")
    return kinds


def specimen_spec(kind: str) -> ParameterSpec:
    """Prior box of a specimen-level parameter: ``scale`` log-uniform on [0.05, 20]; ``angle`` uniform on
    [0, 60] degrees (family 2/3 half-angle; the paper's 20.05 in the middle third)."""
    if kind == "scale":
        return ParameterSpec("scale", "1", 0.05, 20.0, prior="loguniform", value=1.0)
    if kind == "angle":
        return ParameterSpec("angle", "deg", 0.0, 60.0, prior="uniform", value=PAPER_HALF_ANGLE_DEG)
    raise ValidationError("specimen parameter kind", kind, "'scale' or 'angle'")


class SpecimenForward:
    """Forward model of ``experiment`` taking ``(n_sets, n_material + k)``: the material parameters of its tissue
    (:attr:`TissueConfig.param_names`), then ``k`` extra columns; ``kind`` None ignores the extras, otherwise
    :func:`specimen_kinds` names the extra columns in order (``"scale"`` multiplies every modulus mu, kappa,
    ginf_k; ``"angle"`` sets the family 2/3 half-angle)."""

    def __init__(self, experiment: Experiment, kind: str | None = None):
        self.experiment, self.kinds = experiment, specimen_kinds(kind)
        self.model = ForwardModel(experiment)
        self.n_material = len(experiment.tissue.param_names)
        self.moduli = experiment.tissue.modulus_indices()

    def __call__(self, params) -> np.ndarray:
        p = np.atleast_2d(np.asarray(params, dtype=float))
        mat = p[:, : self.n_material].copy()
        extra = dict(zip(self.kinds, p[:, self.n_material : self.n_material + len(self.kinds)].T, strict=True))
        if "scale" in extra:
            mat[:, self.moduli] *= extra["scale"][:, None]
        if "angle" not in extra:
            return self.model(mat)
        out = np.empty((p.shape[0], self.experiment.time_s.size))
        angles = extra["angle"]
        for a in np.unique(angles):  # one batched solve per distinct angle (a difference Jacobian has two)
            rows = angles == a
            tis = tissue_with_half_angle(self.experiment.tissue, a)
            out[rows] = ForwardModel(replace(self.experiment, tissue=tis))(mat[rows])
        return out


class ExperimentResiduals:
    """Stacked scaled residuals of ``experiments`` as a function of the 11 material parameters.

    ``r(theta)`` for ``theta`` (11,) -> (n_obs_total,), or (n_sets, 11) -> (n_sets, n_obs_total);
    NaN where a solve failed. :meth:`predict` gives the stacked predictions (the same shapes).
    """

    def __init__(self, experiments, *, sd: float | None = None):
        self.experiments = tuple(experiments)
        if not self.experiments:
            raise ValidationError("experiments", (), "at least one Experiment")
        for e in self.experiments:
            if e.observed is None:
                raise ValidationError(f"experiment {e.name}", f"no {e.observable[0]} data", "observed data")
        self.models = tuple(ForwardModel(e) for e in self.experiments)
        self.sd = np.concatenate([np.full(e.time_s.size, noise_sd(e, sd)) for e in self.experiments])
        self.observed = np.concatenate([e.observed for e in self.experiments])

    def predict(self, theta) -> np.ndarray:
        return np.concatenate([m(theta) for m in self.models], axis=-1)

    def __call__(self, theta) -> np.ndarray:
        return (self.observed - self.predict(theta)) / self.sd


#: The mirror model's free parameters: the paper's 11 less those :data:`bayestissue.paper.MIRROR_TIES` ties.
MIRROR_NAMES = tuple(n for n in param_names(3) if n not in dict(MIRROR_TIES))
#: Column of each of the paper's 11 parameters in a mirror-model vector.
_MIRROR_COLUMNS = [MIRROR_NAMES.index(dict(MIRROR_TIES).get(n, n)) for n in param_names(3)]


class MirrorResiduals:
    """:class:`ExperimentResiduals` as a function of the mirror model's parameters (:data:`MIRROR_NAMES`: ``mu,
    kappa``, family 1, family 2; family 3 takes family 2's law): ``r(theta8)``."""

    def __init__(self, residuals: ExperimentResiduals):
        self.residuals = residuals

    @staticmethod
    def expand(theta) -> np.ndarray:
        """Mirror-model parameters ``(..., 8)`` -> the paper's 11, tied ones copied from their targets."""
        return np.asarray(theta, dtype=float)[..., _MIRROR_COLUMNS]

    def predict(self, theta) -> np.ndarray:
        return self.residuals.predict(self.expand(theta))

    def __call__(self, theta) -> np.ndarray:
        return self.residuals(self.expand(theta))

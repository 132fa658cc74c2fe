"""Experiments + configuration -> the calibration problem: where mechanics meets inference.

:func:`build_problem` is the one way the CLI, the studies and the dask tasks turn mechanics experiments into a
generic :class:`~bayestissue.inference.CalibrationProblem`: the paper's parameters with Table 1 boxes
(:func:`paper_parameter_set`), the configured fixed / sampled / tied subsets and priors, one
:class:`~bayestissue.inference.ExperimentTerm` per experiment (shared material parameters, one noise model
each, the forward model of :mod:`bayestissue.workflows.forward`), an optional specimen-level parameter, and the
sampler's coordinate system with the tissue geometry the creep-curve coordinates need (:func:`creep_geometry`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.inference import CalibrationProblem, ExperimentTerm, ParameterSet, ParameterSpec, make_noise
from bayestissue.inference.ordering import OrderedGroup
from bayestissue.mechanics import PAPER_TISSUE, ForwardModel, TissueConfig, parse_parameters
from bayestissue.mechanics.presets import preset
from bayestissue.paper import PAPER_PARAMETERS
from bayestissue.workflows.config import CalibrationConfig
from bayestissue.workflows.coordinates import coordinate_factory
from bayestissue.workflows.forward import SpecimenForward, noise_sd, specimen_kinds, specimen_spec

__all__ = [
    "build_problem",
    "creep_geometry",
    "paper_parameter_set",
    "parameter_set",
    "reference_stretch",
    "reference_values",
]


def parameter_set(tissue, *, prior: str = "default", fixed_inputs: Mapping | None = None) -> ParameterSet:
    """The material parameters of ``tissue``'s laws as the inference layer's parameter set.

    Every parameter's box, unit, scale and initial value come from its law's specification
    (:attr:`~bayestissue.mechanics.TissueConfig.parameters`), its box moved by the tissue's preset for its component
    and role (:meth:`~bayestissue.mechanics.presets.TissuePreset.box`).

    Parameters
    ----------
    tissue : TissueConfig
    prior : ``"default"`` (log-uniform on a log-scale box, uniform on a linear one) or ``"uniform"`` (uniform on
        every box: the literal reading of the paper's constraints).
    fixed_inputs : recorded non-parameter inputs (volume fractions, directions, K, eps0).

    References
    ----------
    Paper Section 3.2 and Table 1 (the defaults of the paper's laws, :mod:`bayestissue.mechanics.laws`).
    """
    if prior not in ("default", "uniform"):
        raise ValidationError("prior", prior, "'default' or 'uniform'")
    box = preset(tissue.preset)
    specs = []
    for spec, component in zip(tissue.parameters, tissue.components(), strict=True):
        lo, hi, value = box.box(component, spec)
        specs.append(
            ParameterSpec(
                name=spec.name,
                unit=spec.unit,
                lower=lo,
                upper=hi,
                prior="loguniform" if spec.scale == "log" and prior == "default" else "uniform",
                scale=spec.scale,
                value=value,
            )
        )
    ordered = tuple(OrderedGroup(terms, exchangeable) for terms, exchangeable in tissue.label_groups)
    return ParameterSet(tuple(specs), dict(fixed_inputs or {}), ordered)


def paper_parameter_set(n_fibres: int = 3, *, prior: str = "default", fixed_inputs: Mapping | None = None):
    """The paper's laws (Mooney-Rivlin matrix, Kelvin fibres) for ``n_fibres`` families: Table 1's boxes and the
    paper's initial guess (:func:`parameter_set` of such a tissue)."""
    d = np.tile([[1.0, 0.0, 0.0]], (n_fibres, 1))
    tissue = PAPER_TISSUE if n_fibres == 3 else TissueConfig(d, [0.0] * n_fibres, 1.0)
    return parameter_set(tissue, prior=prior, fixed_inputs=fixed_inputs)


def reference_values(experiment) -> dict[str, np.ndarray]:
    """Known parameter values for an experiment: the paper's Table 1 result (``paper``) for T1/T2 and the
    generating values of a synthetic replica (``generating``, from the data file header), each only where it is in
    the experiment's model (the data fitted with other laws have no values to compare with)."""
    out = {}
    if experiment.name in PAPER_PARAMETERS and experiment.tissue.is_paper_model:
        out["paper"] = np.asarray(PAPER_PARAMETERS[experiment.name], dtype=float)
    gen = (experiment.meta or {}).get("generating_parameters")
    if gen:
        try:
            out["generating"] = parse_parameters(re.sub(r"\s+", "", str(gen)), experiment.tissue.parameters)
        except ValidationError:  # generated under other laws: their names are not this model's
            return out
        if experiment.noise_sd_mm is not None:
            out["noise_sd"] = float(experiment.noise_sd_mm)
    return out


def reference_stretch(experiments) -> float:
    """The data's typical stretch :math:`\\lambda_r = 1 + \\overline{u}/L_x`: the mean observed displacement over
    the specimen length, averaged over the experiments (at least 1.05)."""
    vals = [1.0 + float(np.mean(np.abs(e.displacement_mm))) / float(e.specimen_mm[0]) for e in experiments]
    return max(float(np.mean(vals)), 1.05)


def creep_geometry(experiments, tied: Mapping[str, str]) -> dict:
    """What the creep-curve coordinates need of the mechanics (plain numbers): the reference stretch of the data,
    the matrix volume fraction and ``(phi_k, v_k)`` of every fibre family that uses family 2's law (family 2 and
    each family tied to it), from the first experiment's tissue."""
    tissue = experiments[0].tissue
    fibres = [
        (tissue.phi_fibres[k], tissue.directions[k])
        for k in range(tissue.n_fibres)
        if f"ginf{k + 1}" == "ginf2" or tied.get(f"ginf{k + 1}") == "ginf2"
    ]
    return {"stretch": reference_stretch(experiments), "phi_matrix": tissue.phi_matrix, "fibres": fibres}


def _fixed_inputs(experiments) -> dict:
    """Non-parameter inputs of every experiment, recorded with the results (provenance)."""
    inputs = {}
    for e in experiments:
        t = e.tissue
        inputs.update(
            {
                f"{e.name}_directions": np.asarray(t.directions, dtype=float).ravel(),
                f"{e.name}_phi_fibres": np.asarray(t.phi_fibres, dtype=float),
                f"{e.name}_phi_matrix": float(t.phi_matrix),
                f"{e.name}_bulk_kpa": float(t.bulk_kpa),
                f"{e.name}_eps0": np.asarray(t.eps0 if t.eps0 is not None else np.zeros(t.n_fibres), dtype=float),
                f"{e.name}_specimen_mm": np.asarray(e.specimen_mm, dtype=float),
                f"{e.name}_dt_s": float(e.dt_s),
            }
        )
    return inputs


def _material(experiments, config: CalibrationConfig) -> ParameterSet:
    n_f = {e.tissue.n_fibres for e in experiments}
    if len(n_f) != 1:
        raise ValidationError("experiments", sorted(n_f), "the same number of fibre systems")
    presets = {e.tissue.preset for e in experiments}
    if len(presets) != 1:
        raise ValidationError("experiments' tissue presets", sorted(presets), "one preset (one material)")
    laws = {e.tissue.param_names for e in experiments}
    if len(laws) != 1:
        raise ValidationError("experiments' laws", sorted(", ".join(n) for n in laws),
                              "the same laws (one material: the same parameters)")  # fmt: skip
    material = parameter_set(experiments[0].tissue, prior=config.prior, fixed_inputs=_fixed_inputs(experiments))
    fixed = config.fixed
    fixed_map = dict(fixed) if isinstance(fixed, Mapping) else {n: None for n in fixed}
    if config.sampled is not None:
        sampled = list(config.sampled)
        unknown = sorted(set(sampled) - set(material.names))
        if unknown:
            raise ValidationError("sampled parameter names", unknown, f"names among {list(material.names)}")
        both = sorted(set(fixed_map) & set(sampled))
        if both:
            raise ValidationError("parameters", both, "each parameter either fixed or sampled, not both")
        for n in material.names:  # the rest are held at their initial values
            if n not in sampled and n not in fixed_map and n not in config.tied:
                fixed_map[n] = None
    material = material.updated(
        fixed=fixed_map,
        sampled=config.sampled,
        bounds=config.bounds,
        priors=config.priors,
        initial=config.initial,
        tied=config.tied,
    )
    if material.n_sampled == 0:
        raise ValidationError("sampled parameters", [], "at least one sampled material parameter")
    if config.specimen is not None:
        kind, target = config.specimen
        if target not in [e.name for e in experiments]:
            raise ValidationError("specimen target", target, f"one of {[e.name for e in experiments]}")
        extra = tuple(specimen_spec(k) for k in specimen_kinds(kind))
        material = ParameterSet(material.specs + extra, material.fixed_inputs, material.ordered)
    return material


def _noise(e, config: CalibrationConfig):
    opts = dict(config.noise_options)
    if opts.get("sd") == "data":
        opts["sd"] = noise_sd(e)
    return make_noise(config.noise, **opts)


def _forward(e, config: CalibrationConfig):
    if config.specimen is not None and config.specimen[1] == e.name:
        return SpecimenForward(e, config.specimen[0])
    if config.specimen is not None:
        return SpecimenForward(e)
    return ForwardModel(e)


def build_problem(experiments: Sequence, config: CalibrationConfig | None = None) -> CalibrationProblem:
    """The calibration problem of mechanics ``experiments`` (shared material parameters).

    Raises
    ------
    ValidationError
        If an experiment has no displacement data, the experiments have different fibre counts, or the parameter
        configuration is invalid (unknown names, both fixed and sampled, bad bounds, unknown specimen target).
    """
    config = config or CalibrationConfig()
    experiments = list(experiments)
    if not experiments:
        raise ValidationError("experiments", [], "at least one experiment")
    material = _material(experiments, config)
    terms = []
    for e in experiments:
        channels = [(c, ch) for c, ch in enumerate(e.channels) if e.data_of(ch) is not None]
        if not channels:
            first = e.channels[0]
            raise ValidationError(f"experiment {e.name}", f"no {first.column} column", f"{first.quantity} data to fit")
        forward = _forward(e, config)
        if len(e.channels) > 1 and not isinstance(forward, ForwardModel):
            raise ValidationError(f"experiment {e.name}", f"{len(e.channels)} observed channels",
                                  "one channel with a specimen-level parameter")  # fmt: skip
        for c, ch in channels:  # one term per observed channel: each its own noise model
            fwd = forward if len(e.channels) == 1 else forward.channel(c)
            terms.append(
                ExperimentTerm(
                    e.name if c == 0 else f"{e.name}_{c + 1}",
                    e.time_s,
                    e.data_of(ch),
                    fwd,
                    _noise(e, config),
                    {"synthetic": bool(e.synthetic), "source": str(e.source or ""), "observable": ch.label},
                    unit=ch.unit,
                    sensitivities=fwd.sensitivities if isinstance(forward, ForwardModel) else None,
                )
            )
    if config.coordinates != "box" and not all(e.tissue.is_paper_model for e in experiments):
        raise ValidationError("sampler coordinates", config.coordinates,
                              "'box' for laws other than the paper's (the creep and ramp coordinates are those of its "
                              "Mooney-Rivlin matrix and Kelvin fibre)")  # fmt: skip
    geometry = creep_geometry(experiments, material.tied) if config.coordinates == "creep" else None
    return CalibrationProblem(
        terms, material, exchangeable=config.exchangeable, coordinates=coordinate_factory(config.coordinates, geometry)
    )

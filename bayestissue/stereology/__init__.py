"""Quantitative microscopy (paper Sections 2.5 and 3.1): volume fractions, length density, fibre
directions.

Modules: :mod:`~.sections` (SURS, point counts, V_V and its CE), :mod:`~.lines` (line systems, L_V),
:mod:`~.rose` (equal-area rose of directions, Lambert projection), :mod:`~.axial` (orientation
tensor, Watson distribution and mixtures), :mod:`~.uncertainty` (bootstraps done right for
systematic samples), :mod:`~.replicates` (the joint replicate table for the mechanics),
:mod:`~.known_object` (an analytic phantom for checking CE predictors). The synthetic tissue phantom
and the micrograph pipeline: :mod:`bayestissue.stereology.micrographs`.
"""

from bayestissue.stereology.axial import (
    WatsonMixture,
    axial_angle,
    fit_watson,
    fit_watson_mixture,
    goh_dispersion,
    orientation_tensor,
    principal_axes,
    sample_watson,
    watson_goh_dispersion,
    watson_logpdf,
    watson_pdf,
)
from bayestissue.stereology.known_object import TwoBallPhantom, ce_check, simulate_surs_counts
from bayestissue.stereology.lines import (
    LineSystem,
    azimuth_elevation,
    length_density,
    segments_from_polylines,
    stack_volume,
    to_upper_hemisphere,
    unit_vector,
)
from bayestissue.stereology.point_counts import PointCounts
from bayestissue.stereology.replicates import (
    direction_bootstrap,
    fibre_fraction_split,
    fit_fibre_directions,
    fraction_replicates,
    replicate_table,
    stereology_replicates,
)
from bayestissue.stereology.rose import (
    EqualAreaRose,
    directions_vs_n,
    lambert_project,
    lambert_ring_radii,
    preferential_directions,
    rose_of_directions,
)
from bayestissue.stereology.sections import (
    alpha_q,
    ce_sum,
    classic_ratio_ce,
    fraction_covariance,
    nugget_variance,
    ratio_ce,
    smoothness_q_hat,
    surs_indices,
    surs_sum_variance,
)
from bayestissue.stereology.uncertainty import (
    align_axes,
    bootstrap_cells,
    cluster_fraction_bootstrap,
    confidence_cones,
    logistic_normal_draws,
    naive_section_bootstrap,
    parametric_fraction_bootstrap,
)

__all__ = [
    "EqualAreaRose",
    "LineSystem",
    "PointCounts",
    "TwoBallPhantom",
    "WatsonMixture",
    "align_axes",
    "alpha_q",
    "axial_angle",
    "azimuth_elevation",
    "bootstrap_cells",
    "ce_check",
    "ce_sum",
    "classic_ratio_ce",
    "cluster_fraction_bootstrap",
    "confidence_cones",
    "directions_vs_n",
    "fibre_fraction_split",
    "stereology_replicates",
    "fraction_replicates",
    "fit_fibre_directions",
    "direction_bootstrap",
    "fit_watson",
    "fit_watson_mixture",
    "fraction_covariance",
    "goh_dispersion",
    "lambert_project",
    "lambert_ring_radii",
    "length_density",
    "logistic_normal_draws",
    "naive_section_bootstrap",
    "nugget_variance",
    "orientation_tensor",
    "parametric_fraction_bootstrap",
    "preferential_directions",
    "principal_axes",
    "ratio_ce",
    "replicate_table",
    "rose_of_directions",
    "sample_watson",
    "segments_from_polylines",
    "simulate_surs_counts",
    "smoothness_q_hat",
    "stack_volume",
    "surs_indices",
    "surs_sum_variance",
    "to_upper_hemisphere",
    "unit_vector",
    "watson_logpdf",
    "watson_goh_dispersion",
    "watson_pdf",
]

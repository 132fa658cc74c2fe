"""Identifiability: local sensitivities and collinearity, profile likelihoods,
posterior-versus-prior measures, and the comparison of experiments (tension, cross-prediction).

Layer: array functions; imports inference only, never mechanics, workflows, plotting or cli.
"""

from bayestissue.identifiability.compare import (
    coverage,
    gaussian_loglik,
    log_predictive_density,
    predictive_band,
    psis_leave_out,
    tension,
)
from bayestissue.identifiability.posterior import (
    batch_means,
    bhattacharyya,
    bound_flags,
    contraction,
    correlation_matrix,
    kl_divergence,
    principal_angles,
    uninformed,
    uninformed_mc,
)
from bayestissue.identifiability.profile import (
    CHI2_1_95,
    ProfileOptions,
    ProfileResult,
    classify_profile,
    fit_residuals,
    profile_likelihood,
)
from bayestissue.identifiability.restarts import ProfileSet, profile_all
from bayestissue.identifiability.sensitivity import (
    SensitivityAnalysis,
    analyse_sensitivities,
    collinearity_index,
    collinearity_table,
    informed_directions,
    largest_identifiable_subsets,
    scaled_sensitivities,
)

__all__ = [
    "CHI2_1_95",
    "ProfileOptions",
    "ProfileResult",
    "ProfileSet",
    "SensitivityAnalysis",
    "analyse_sensitivities",
    "batch_means",
    "bhattacharyya",
    "bound_flags",
    "classify_profile",
    "collinearity_index",
    "collinearity_table",
    "contraction",
    "correlation_matrix",
    "coverage",
    "fit_residuals",
    "gaussian_loglik",
    "informed_directions",
    "kl_divergence",
    "largest_identifiable_subsets",
    "log_predictive_density",
    "predictive_band",
    "principal_angles",
    "profile_all",
    "profile_likelihood",
    "psis_leave_out",
    "scaled_sensitivities",
    "tension",
    "uninformed",
    "uninformed_mc",
]

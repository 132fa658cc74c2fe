"""Workflows: the calibration pipeline, the one place where mechanics meets inference.

config -> problem -> warm start -> sampler -> result, shared by the CLI (``bayestissue fit``), the studies and the
dask tasks (the study analyses built on it live in :mod:`bayestissue.analyses`, the report in
:mod:`bayestissue.report`):

* :mod:`~bayestissue.workflows.config` -- the calibration configuration's one typed schema;
* :mod:`~bayestissue.workflows.forward` -- forward models with specimen-level parameters, scaled residuals;
* :mod:`~bayestissue.workflows.problem` -- experiments + configuration -> the calibration problem;
* :mod:`~bayestissue.workflows.calibration` -- the full pipeline with its results files (``run_calibration``);
* :mod:`~bayestissue.workflows.tasks` -- picklable calibration tasks for the identifiability studies (``run_task``);
* :mod:`~bayestissue.workflows.run_directory` -- a run's output folder: lock, manifest, resume checks.

Layer: imports io, mechanics, inference and identifiability; never plotting or cli.
"""

from bayestissue.workflows.calibration import CalibrationOutcome, run_calibration
from bayestissue.workflows.config import CalibrationConfig, config_from_mapping, load_config
from bayestissue.workflows.forward import ExperimentResiduals, SpecimenForward, noise_sd, specimen_spec
from bayestissue.workflows.problem import build_problem, paper_parameter_set, reference_values
from bayestissue.workflows.tasks import (
    CalibrationDraws,
    CalibrationTask,
    attach_posterior,
    drop_stuck_draws,
    run_task,
    task_problem,
)

__all__ = [
    "CalibrationConfig",
    "CalibrationDraws",
    "CalibrationOutcome",
    "CalibrationTask",
    "ExperimentResiduals",
    "SpecimenForward",
    "attach_posterior",
    "build_problem",
    "config_from_mapping",
    "drop_stuck_draws",
    "load_config",
    "noise_sd",
    "paper_parameter_set",
    "reference_values",
    "run_calibration",
    "run_task",
    "specimen_spec",
    "task_problem",
]

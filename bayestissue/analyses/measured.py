r"""Calibration of the matrix (Mooney-Rivlin) on real, elastic, stretch-controlled data (``data/measured/``): Treloar's
rubber in uniaxial tension, against the closed-form fit.

Each case is a bundled measured curve (nominal stress against stretch, lateral faces free), a stretch range and a
parameter box for the material's scale; :func:`trimmed` cuts the experiment to the range. The independent check is
the closed-form incompressible fit: with :math:`\mu = 2 C_{10}`, :math:`\kappa = 2 C_{01}` the matrix of
docs/model.md under incompressible uniaxial stretch gives

.. math:: P_{11} = (\lambda - \lambda^{-2})(\mu + \kappa/\lambda) = 2(\lambda - \lambda^{-2})(C_{10} + C_{01}/\lambda),

linear in :math:`(\mu, \kappa)`: ordinary least squares on the same points (:func:`incompressible_fit`, unweighted
like the calibration's Gaussian likelihood with one sd), without the box (so :math:`\kappa < 0` can come out where
the box of the calibration stops at its lower bound).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bayestissue.mechanics import Experiment
from bayestissue.mechanics.protocols import MeasuredStretchProtocol

__all__ = ["MeasuredCase", "CASES", "trimmed", "incompressible_fit", "incompressible_stress"]


@dataclass(frozen=True)
class MeasuredCase:
    """One calibration of a bundled measured curve: ``file`` (under ``data/measured/``), the largest stretch fitted
    and the sampling engine; the boxes of mu and kappa are the file's tissue preset's (docs/presets.md)."""

    name: str
    file: str
    max_stretch: float
    material: str
    engine: str = "emcee"


#: Treloar's rubber over stretch <= 3 (where Mooney-Rivlin fits are usually made) and over the whole range (to 7.6,
#: with the upturn it cannot follow); box: the preset ``rubber`` ([1, 1e5] kPa), two to three decades either side of
#: the material's known scale. Brain tissue (Budday 2017) is calibrated in tension, compression and shear by the laws
#: stage (:mod:`bayestissue.analyses.law_choice`), its Mooney-Rivlin fit on tension alone among them.
CASES = (
    MeasuredCase("treloar_to_3", "treloar_1944.toml", 3.0, "rubber (Treloar 1944)"),
    MeasuredCase("treloar_all", "treloar_1944.toml", np.inf, "rubber (Treloar 1944)"),
)


def trimmed(experiment: Experiment, max_stretch: float) -> Experiment:
    """The measured-stretch ``experiment`` cut to the data points with stretch <= ``max_stretch``."""
    lam = experiment.protocol.stretch
    keep = lam <= max_stretch
    if keep.all():
        return experiment
    protocol = MeasuredStretchProtocol(experiment.protocol.time_s[keep], lam[keep])
    columns = {k: getattr(experiment, k) for k in ("displacement_mm", "force_mN", "stress_kpa")}
    cut = {k: None if v is None else v[keep] for k, v in columns.items()}
    extra = {k: v[keep] for k, v in experiment.columns.items()}  # the data file's other columns (e.g. stretch)
    return replace(experiment, protocol=protocol, time_s=experiment.time_s[keep], columns=extra, **cut)


def incompressible_stress(stretch, mu, kappa) -> np.ndarray:
    """Nominal stress of the incompressible Mooney-Rivlin matrix in uniaxial stretch (module docstring)."""
    lam = np.asarray(stretch, dtype=float)
    return (lam - lam**-2) * (mu + kappa / lam)


def incompressible_fit(stretch, stress) -> tuple[float, float, float]:
    """Least-squares ``(mu, kappa, rms)`` of :func:`incompressible_stress` to the points (unconstrained)."""
    lam = np.asarray(stretch, dtype=float)
    A = np.column_stack([lam - lam**-2, (lam - lam**-2) / lam])
    (mu, kappa), *_ = np.linalg.lstsq(A, np.asarray(stress, dtype=float), rcond=None)
    rms = float(np.sqrt(np.mean((A @ [mu, kappa] - stress) ** 2)))
    return float(mu), float(kappa), rms

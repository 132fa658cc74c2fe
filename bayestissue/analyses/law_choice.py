r"""Which constitutive law do measured curves in several modes support? (issue 32's real-data cases)

A *material* is a set of bundled measured curves of one material in different modes (``data/measured/``): Treloar's
rubber in uniaxial tension, equibiaxial tension and pure shear; a brain region of Budday et al. (2017) in uniaxial
tension, compression and simple shear. A *candidate* is a matrix law of the registry with its options
(:mod:`bayestissue.mechanics.laws`). Two questions per material and law:

* **Transfer**: calibrated on the first mode alone, how well does the law predict the others? Measured by the share of
  each other curve inside the 90 % posterior predictive band
  (:func:`~bayestissue.identifiability.compare.coverage`; the band is that of a new
  measurement: the model curve at each posterior draw plus Gaussian noise with the draw's noise sd of the calibrated
  mode, the only noise the calibration knows) and by the root-mean-square error of the median prediction relative to
  the curve's range.
* **Joint evidence**: calibrated on all modes at once (one noise sd per mode, integrated out), the log evidence
  :math:`\ln Z` of each law with its Monte Carlo error (the nested engine's runs); the log Bayes factor of the best
  law over each other is :math:`\Delta\ln Z` with error :math:`\sqrt{\epsilon_a^2 + \epsilon_b^2}`
  (:func:`bayes_factors`), graded by :func:`bayestissue.analyses.verdicts.evidence_strength`.

The priors are the tissue preset's boxes (docs/presets.md, docs/laws.md): the same for a parameter shared by two laws,
so the factor weighs fit against the volume of the prior each law must spread over.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from bayestissue.mechanics import Experiment
from bayestissue.mechanics.laws import matrix_law

__all__ = [
    "BRAIN_LAWS",
    "BUDDAY_ALPHA",
    "Candidate",
    "MATERIALS",
    "Material",
    "RUBBER_LAWS",
    "bayes_factors",
    "relative_rms",
    "with_matrix",
]


@dataclass(frozen=True)
class Candidate:
    """A matrix law to compare: its ``label`` in tables, its registry name and options."""

    label: str
    matrix: str
    options: dict = field(default_factory=dict)

    def law(self):
        return matrix_law(self.matrix, **self.options)


NEO_HOOKEAN = Candidate("neo-Hookean", "neo_hookean")
MOONEY_RIVLIN = Candidate("Mooney-Rivlin", "mooney_rivlin")
OGDEN = tuple(Candidate(f"Ogden {n}", "ogden", {"terms": n}) for n in (1, 2, 3))
#: Treloar's rubber: the laws of the classic comparison (issue 32).
RUBBER_LAWS = (NEO_HOOKEAN, MOONEY_RIVLIN, *OGDEN)
#: Brain tissue: Mooney-Rivlin against the one-term Ogden law of Budday et al. (2017), neo-Hookean as the baseline.
BRAIN_LAWS = (NEO_HOOKEAN, MOONEY_RIVLIN, OGDEN[0])


@dataclass(frozen=True)
class Material:
    """Measured curves of one material: ``files`` under ``data/measured/`` (the first is the transfer test's
    calibration mode), ``modes`` their labels, the ``laws`` compared, and a published one-term Ogden exponent range
    to compare with (``alpha_published``, None where there is none)."""

    name: str
    title: str
    files: tuple[str, ...]
    modes: tuple[str, ...]
    laws: tuple[Candidate, ...]
    alpha_published: tuple[float, float] | None = None


#: Budday et al. (2017): the one-term Ogden law fitting tension, compression and shear together has alpha about -20
#: to -25 (as ../shared/external/README.md summarises the paper; docs/report_guide.md#which-law).
BUDDAY_ALPHA = (-25.0, -20.0)


MATERIALS = (
    Material(
        "treloar",
        "rubber (Treloar 1944)",
        ("treloar_1944.toml", "treloar_1944_equibiaxial.toml", "treloar_1944_pure_shear.toml"),
        ("uniaxial tension", "equibiaxial tension", "pure shear"),
        RUBBER_LAWS,
    ),
    Material(
        "basal_ganglia",
        "brain, basal ganglia (Budday 2017)",
        ("budday_2017_basal_ganglia.toml", "budday_2017_basal_ganglia_compression.toml",
         "budday_2017_basal_ganglia_shear.toml"),
        ("tension", "compression", "simple shear"),
        BRAIN_LAWS,
        BUDDAY_ALPHA,
    ),
    Material(
        "corpus_callosum",
        "brain, corpus callosum (Budday 2017)",
        ("budday_2017_corpus_callosum.toml", "budday_2017_corpus_callosum_compression.toml",
         "budday_2017_corpus_callosum_shear.toml"),
        ("tension", "compression", "simple shear"),
        BRAIN_LAWS,
        BUDDAY_ALPHA,
    ),
)  # fmt: skip


def with_matrix(experiment: Experiment, candidate: Candidate) -> Experiment:
    """``experiment`` with its tissue's matrix law replaced by the candidate's."""
    return replace(experiment, tissue=replace(experiment.tissue, matrix=candidate.law()))


def relative_rms(prediction, observed) -> float:
    """Root-mean-square of ``prediction - observed`` relative to the observed curve's range (peak to peak)."""
    obs = np.asarray(observed, dtype=float)
    return float(np.sqrt(np.mean((np.asarray(prediction, dtype=float) - obs) ** 2)) / np.ptp(obs))


def bayes_factors(log_z: dict[str, float], errors: dict[str, float]) -> tuple[str, dict[str, tuple[float, float]]]:
    """The law of largest evidence and, for every law, the log Bayes factor of that law over it with its error
    (module docstring); the best law's own entry is (0, 0)."""
    best = max(log_z, key=lambda k: log_z[k])
    out = {}
    for k in log_z:
        if k == best:
            out[k] = (0.0, 0.0)
        else:
            out[k] = (float(log_z[best] - log_z[k]), float(np.hypot(errors[best], errors[k])))
    return best, out

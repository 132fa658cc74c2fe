"""Micrographs: a synthetic histology phantom with known truth and the image pipeline that measures it.

Modules: :mod:`~.phantom` (tissue blocks of spindle cells), :mod:`~.render` (Mallory-trichrome sections with
misregistration), :mod:`~.registration`, :mod:`~.segmentation`, :mod:`~.gridcount` (point grids on sections),
:mod:`~.tracing` (cell axes for L_V and directions), :mod:`~.pipeline` (:func:`analyse_micrographs`).
"""

from bayestissue.stereology.micrographs.pipeline import MicrographAnalysis, analyse_micrographs

__all__ = ["MicrographAnalysis", "analyse_micrographs"]

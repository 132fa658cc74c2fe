"""The micrograph pipeline: serial sections -> registration -> segmentation -> point grid + traced cells.

:func:`analyse_micrographs` chains :mod:`~.registration`, :mod:`~.segmentation`, :mod:`~.gridcount` (point
counts on a SURS sample of sections) and :mod:`~.tracing` (cell axes); :class:`MicrographAnalysis` hands the
results to the stereology estimators as :class:`~bayestissue.stereology.sections.PointCounts` and
:class:`~bayestissue.stereology.lines.LineSystem`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.stereology.lines import LineSystem
from bayestissue.stereology.micrographs.gridcount import COMPONENTS, GridCounts, count_points
from bayestissue.stereology.micrographs.phantom import SMC
from bayestissue.stereology.micrographs.registration import RegisteredStack, register_stack
from bayestissue.stereology.micrographs.segmentation import (
    Segmentation,
    check_rgb_stack,
    segment_stack,
    threshold_sensitivity,
)
from bayestissue.stereology.micrographs.tracing import TracedCells, trace_cells
from bayestissue.stereology.point_counts import PointCounts
from bayestissue.stereology.sections import surs_indices

__all__ = ["MicrographAnalysis", "analyse_micrographs"]


@dataclass
class MicrographAnalysis:
    """Everything :func:`analyse_micrographs` produced, for writing or further analysis."""

    registered: RegisteredStack
    segmentation: Segmentation
    sensitivity: list
    grid: GridCounts
    traced: TracedCells
    pixel_um: float
    thickness_um: float

    def point_counts(self) -> PointCounts:
        """The grid counts as the stereology :class:`PointCounts` (reference = tissue)."""
        return PointCounts(
            self.grid.section,
            self.grid.counts,
            COMPONENTS,
            ("cavity",),
            grid_spacing_um=self.grid.spacing_px * self.pixel_um,
        )

    def line_system(self) -> LineSystem:
        """The traced segments as the stereology :class:`LineSystem`."""
        s = self.traced.segments_um
        return LineSystem(s[:, 0], s[:, 1], self.traced.cell_id, self.traced.volume_um3)


def analyse_micrographs(
    images,
    *,
    pixel_um: float,
    thickness_um: float,
    grid_spacing_um: float = 10.0,
    period: int = 2,
    method: str = "deconvolution",
    rng=None,
    progress=None,
    stage=None,
) -> MicrographAnalysis:
    """Run the pipeline: register, segment, count the point grid on a SURS sample, trace cells.

    Parameters
    ----------
    images : (n, H, W, 3) RGB serial sections (all the same size).
    pixel_um, thickness_um : pixel size and section thickness in um (required: no default is safe).
    grid_spacing_um : spacing of the point grid; period : every ``period``-th section is counted
        (random start).
    method : colour segmentation method ("deconvolution" or "lab").
    rng : seed or Generator (SURS start, grid offsets, k-means starts).
    progress : optional callable(n_done) (e.g. ``tqdm.update``): 1 per registered section (n - 1), then 1 after
        segmentation, counting and tracing (n + 2 in all).
    stage : optional callable(name) at the start of each stage (e.g. ``tqdm.set_description``).
    """
    rng = np.random.default_rng(rng)
    if pixel_um is None:
        raise ValidationError("pixel_um", None, "the pixel size in um (e.g. from the microscope)")
    if thickness_um is None:
        raise ValidationError("thickness_um", None, "the section thickness in um")
    pixel_um = check_positive("pixel_um", pixel_um)
    thickness_um = check_positive("thickness_um", thickness_um)
    grid_spacing_um = check_positive("grid_spacing_um", grid_spacing_um)
    imgs = check_rgb_stack(images)
    step = progress or (lambda k: None)
    say = stage or (lambda name: None)
    say("registering sections")
    reg = register_stack(imgs, progress=step)
    say("segmenting colours")
    seg = segment_stack(reg.images, method=method, valid=reg.valid)
    sens = threshold_sensitivity(reg.images, seg, valid=reg.valid)
    step(1)
    say("counting the point grid")
    sections = surs_indices(len(imgs), min(int(period), len(imgs)), rng=rng)
    grid = count_points(
        seg.labels,
        spacing_px=grid_spacing_um / pixel_um,
        sections=sections,
        valid=reg.valid,
        rng=rng,
    )
    step(1)
    say("tracing cells")
    cells = seg.labels == SMC if seg.seams is None else (seg.labels == SMC) & ~seg.seams  # cut at the seams
    traced = trace_cells(cells, spacing_um=(thickness_um, pixel_um, pixel_um), valid=reg.valid, rng=rng)
    step(1)
    return MicrographAnalysis(reg, seg, sens, grid, traced, pixel_um, thickness_um)

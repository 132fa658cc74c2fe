"""Cell tracing: single cells of known axis, stacked cells kept apart, bad input; and the
phantom's line system against its truth."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.stereology.micrographs.geometry import ellipsoid_voxels
from bayestissue.stereology.micrographs.tip_correction import end_corrected_length, tip_deficit
from bayestissue.stereology.micrographs.tracing import fit_segment, trace_cells

SHAPE = (60, 100, 100)
PLANES = np.floor((np.arange(12) + 0.5) * 5).astype(int)  # 5 um sections of a 1 um volume


def _cell(direction, centre=(50.0, 50.0, 30.0)):
    vol = np.zeros(SHAPE, bool)
    d = np.asarray(direction, float)
    vol[ellipsoid_voxels(np.asarray(centre), d / np.linalg.norm(d), 36.0, 3.0, SHAPE, 1.0)] = True
    return vol


def test_fit_segment_of_a_rod():
    x = np.arange(20) + 0.5
    pts = np.column_stack([x, np.full(20, 3.0), np.full(20, 7.0)])
    seg = fit_segment(pts, (1.0, 1.0, 1.0))
    assert np.linalg.norm(seg[1] - seg[0]) == pytest.approx(20.0)


@pytest.mark.parametrize(("elevation", "lo", "hi"), [(20, 45, 80), (45, 50, 90), (90, 50, 62)])
def test_single_oblique_cell(elevation, lo, hi):
    e = np.radians(elevation)
    d = np.array([np.cos(e), 0.0, np.sin(e)])
    # pieces longer than the section spacing keep the elevation (15 um pieces of a 20 degree
    # cell are single-section profiles, which lie in the section plane: 13 degrees off)
    tc = trace_cells(_cell(d)[PLANES], spacing_um=(5, 1, 1), piece_length_um=40)
    assert np.unique(tc.cell_id).size == 1  # one cell, linked through its sections
    assert lo < tc.lengths_um.sum() < hi  # 72 um (clipped to the 60 um stack when steep)
    axis = np.average(np.abs(tc.directions @ d), weights=tc.lengths_um)
    assert np.degrees(np.arccos(min(axis, 1))) < 12


def test_cells_stacked_in_neighbouring_sections_stay_apart():
    # two in-plane cells crossing at 90 degrees in consecutive sections (z = 27.5, 32.5 um)
    vol = _cell([1, 0, 0], (50, 50, 27.5)) | _cell([0, 1, 0], (50, 50, 32.5))
    mask = vol[PLANES]
    tc = trace_cells(mask, spacing_um=(5, 1, 1))
    assert np.unique(tc.cell_id).size == 2
    assert tc.length_density() * tc.volume_um3 > 100  # two cells' length, not one
    ws = trace_cells(mask, spacing_um=(5, 1, 1), method="watershed", piece_length_um=200)
    assert ws.lengths_um.sum() < tc.lengths_um.sum()  # 3-D connectivity merges them


def test_volume_and_valid_field():
    mask = _cell([1, 0, 0])[PLANES]
    valid = np.zeros(SHAPE[1:], bool)
    valid[:, :60] = True
    tc = trace_cells(mask, spacing_um=(5, 1, 1), valid=valid)
    assert tc.volume_um3 == pytest.approx(100 * 60 * 12 * 5)
    assert tc.segments_um[:, :, 0].max() <= 60.5


def test_bad_tracing_input():
    mask = _cell([1, 0, 0])[PLANES]
    with pytest.raises(ValidationError, match="smc_mask: expected a 3-D stack"):
        trace_cells(mask[0], spacing_um=(5, 1, 1))
    with pytest.raises(ValidationError, match="spacing_um: expected three positive"):
        trace_cells(mask, spacing_um=(5, 1))
    with pytest.raises(ValidationError, match="smc_mask: expected a segmentation with smooth"):
        trace_cells(np.zeros_like(mask), spacing_um=(5, 1, 1))
    with pytest.raises(ValidationError, match="method: expected 'profiles' or 'watershed'"):
        trace_cells(mask, spacing_um=(5, 1, 1), method="skeleton")
    with pytest.raises(ValidationError, match="min_volume_um3"):
        trace_cells(mask, spacing_um=(5, 1, 1), min_volume_um3=1e9)


def test_merged_cells_get_their_length_from_volume():
    shape = (30, 160, 160)
    vol = np.zeros(shape, bool)
    z = 12.5  # on a section mid-plane: every cell shows at full width in one section

    def add(centre, d):
        d = np.asarray(d, float) / np.linalg.norm(d)
        vol[ellipsoid_voxels(np.asarray(centre, float), d, 36.0, 3.0, shape, 1.0)] = True

    for y in (10, 25, 40, 55, 70, 85):  # six separate line-like cells: the cross-section
        add((80, y, z), (1, 0, 0))
    add((80, 125, z), (1, 0.45, 0))  # two cells crossing in the same section: one region
    add((80, 125, z), (1, -0.45, 0))
    mask = vol[np.floor((np.arange(6) + 0.5) * 5).astype(int)]
    single = trace_cells(mask[:, :100], spacing_um=(5, 1, 1)).lengths_um.sum() / 6
    # no cutting into pieces, so that only the volume rule can find the second cell
    on = trace_cells(mask, spacing_um=(5, 1, 1), piece_length_um=200)
    off = trace_cells(mask, spacing_um=(5, 1, 1), piece_length_um=200, length_from_volume=False)
    cross = on.labels[:, 100:].max()
    x_on = on.lengths_um[on.cell_id == cross].sum()
    x_off = off.lengths_um[off.cell_id == off.labels[:, 100:].max()].sum()
    assert x_on == pytest.approx(2 * single, rel=0.2)  # two cells' worth of length
    assert x_off < 1.5 * single  # negative control: the extent alone sees about one cell


def test_short_bridges_between_cells_are_cut_by_the_cores():
    # two parallel in-plane cells 1 px apart, joined by a 2 px bridge (blur merging the cleft in
    # the segmentation): the 1 px cores keep them apart; the full profiles make one cell
    shape = (10, 40, 100)
    vol = _cell_in((50.0, 15.0, 7.5), [1, 0, 0], shape) | _cell_in((50.0, 22.0, 7.5), [1, 0, 0], shape)
    mask = vol[[2, 7]]
    gap_rows = np.flatnonzero(~mask[1, :, 50] & (np.arange(40) > 15) & (np.arange(40) < 22))
    assert gap_rows.size == 1  # a one-pixel cleft
    mask[1, gap_rows[0], 49:51] = True
    cores = trace_cells(mask, spacing_um=(5, 1, 1), piece_length_um=200)
    assert np.unique(cores.cell_id).size == 2
    alone = trace_cells(_cell_in((50.0, 15.0, 7.5), [1, 0, 0], shape)[[2, 7]], spacing_um=(5, 1, 1), core_px=0)
    assert cores.lengths_um == pytest.approx([alone.lengths_um.sum()] * 2, abs=1.5)  # tips given back
    full = trace_cells(mask, spacing_um=(5, 1, 1), piece_length_um=200, core_px=0)
    assert np.unique(full.cell_id).size == 1  # negative control: one merged cell


def test_grazing_loss_of_an_in_plane_cell():
    # a 72 x 6 um spindle lying in the section plane, planes every 5 um at 20 offsets: the traced
    # length is 2 a E[s], s = sqrt(1 - h^2 / b^2), h ~ U[0, 2.5] um (model 0.867; measured 0.847)
    u = np.linspace(0, 2.5, 2001)
    model = np.mean(np.sqrt(1 - (u / 3.0) ** 2))
    shape = (50, 20, 90)
    ratios = []
    for h in np.arange(20) * 0.25:
        vol = _cell_in((45.0, 10.0, 20.0 + h), [1, 0, 0], shape)
        tc = trace_cells(vol[PLANES[:10]], spacing_um=(5, 1, 1), piece_length_um=200, core_px=0)
        ratios.append(tc.lengths_um.sum() / 72.0)
    assert np.mean(ratios) == pytest.approx(model, abs=0.04)
    assert np.mean(ratios) < 0.9  # the bias is real: not the true length


def test_bad_core_px():
    mask = _cell([1, 0, 0])[PLANES]
    with pytest.raises(ValidationError, match="core_px: expected a non-negative number"):
        trace_cells(mask, spacing_um=(5, 1, 1), core_px=-1)
    thin = np.zeros((3, 20, 20), bool)
    thin[1, 10, 2:18] = True
    with pytest.raises(ValidationError, match="no SMC pixel left after eroding by core_px=1"):
        trace_cells(thin, spacing_um=(5, 1, 1))


def _cell_in(centre, direction, shape):
    vol = np.zeros(shape, bool)
    d = np.asarray(direction, float)
    vol[ellipsoid_voxels(np.asarray(centre), d / np.linalg.norm(d), 36.0, 3.0, shape, 1.0)] = True
    return vol


def test_tip_deficit_closed_forms():
    # in the section plane: a (1 - E[s]), E[s] = mean of sqrt(1 - h^2 / b^2), h ~ U[0, T/2]
    u = (np.arange(4000) + 0.5) / 4000 * 2.5
    es = np.mean(np.sqrt(1 - (u / 3.0) ** 2))
    assert tip_deficit(36.0, 3.0, 0.0, 5.0) == pytest.approx(36.0 * (1 - es), rel=0.01)
    # along the section normal the half-section pad makes up the E[delta] = T / 2 lost between planes
    assert tip_deficit(36.0, 3.0, 1.0, 5.0) == pytest.approx(0.0, abs=0.05)
    # the fixed point gives the true length back from the expected traced length
    for sin_elev in (0.0, 0.1, 0.3, 0.7):
        traced = 72.0 - 2 * tip_deficit(36.0, 3.0, sin_elev, 5.0)
        assert end_corrected_length(traced, 3.0, sin_elev, 5.0) == pytest.approx(72.0, rel=0.01)


def test_end_correction_of_an_in_plane_cell():
    # the grazed spindle of test_grazing_loss_of_an_in_plane_cell (0.85 of its length traced) with
    # the end correction and the radius measured from its own profiles: the whole length on average
    shape = (50, 20, 90)
    ratios, plain = [], []
    for h in np.arange(20) * 0.25:
        mask = _cell_in((45.0, 10.0, 20.0 + h), [1, 0, 0], shape)[PLANES[:10]]
        kw = dict(spacing_um=(5, 1, 1), piece_length_um=200, core_px=0)
        ratios.append(trace_cells(mask, end_correction=True, **kw).lengths_um.sum() / 72.0)
        plain.append(trace_cells(mask, **kw).lengths_um.sum() / 72.0)
    assert np.mean(ratios) == pytest.approx(1.0, abs=0.05)
    assert np.std(ratios) < np.std(plain)  # a grazed (thin) profile measures a small radius
    assert np.mean(plain) < 0.9  # negative control: off by default

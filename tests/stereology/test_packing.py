"""The tessellated phantom (cells that do not interpenetrate): its geometry helpers against brute force, and the
phantom's promises -- every axis inside its own voxels, the SMC fraction met, axes apart, cells of the stated size."""

import numpy as np
import pytest

from bayestissue.stereology.micrographs.packing import segment_distances, traversed_voxels
from bayestissue.stereology.micrographs.phantom import SMC, PhantomOptions, make_phantom

TESSELLATED = PhantomOptions(extent_um=(40.0, 80.0, 80.0), packing="tessellation")


def test_segment_distances_against_dense_sampling():
    """To 5e-3 of the length: the dense grids of 501 points per segment resolve the closest pair to about 1e-3."""
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 501)
    for _ in range(10):
        p0, d0 = rng.normal(size=3) * 5, rng.normal(size=3) * 5
        P, D = rng.normal(size=(4, 3)) * 5, rng.normal(size=(4, 3)) * 5
        D[0] = 2.5 * d0  # a parallel pair
        ours = segment_distances(p0, d0, P, D)
        a = p0 + t[:, None] * d0
        for k in range(4):
            b = P[k] + t[:, None] * D[k]
            brute = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)).min()
            assert ours[k] <= brute + 1e-9
            assert ours[k] == pytest.approx(brute, abs=5e-3 * max(np.linalg.norm(d0), np.linalg.norm(D[k])))


def test_traversed_voxels_contain_every_point_of_the_segment():
    rng = np.random.default_rng(4)
    shape = (12, 14, 16)
    for _ in range(20):
        p0 = rng.uniform(0, 12, size=3)
        d = rng.normal(size=3) * 6
        ijk = {tuple(v) for v in traversed_voxels(p0, d, shape, 1.0)}
        pts = p0 + np.linspace(0, 1, 4001)[:, None] * d
        cells = np.floor(pts).astype(int)
        inside = np.all((cells >= 0) & (cells < np.array(shape[::-1])), axis=1)
        assert {tuple(v) for v in cells[inside]} <= ijk  # no voxel the segment enters is missed
        assert len(ijk) <= len({tuple(v) for v in cells[inside]}) + 2  # and none it does not (grazing ends aside)


@pytest.fixture(scope="module")
def phantom():
    return make_phantom(TESSELLATED, rng=7)


def test_axes_lie_inside_their_own_voxels(phantom):
    """The whole axis in tissue is visible: no part of it runs through another cell or a seam."""
    full = phantom.tissue_lengths_um().sum()
    visible = phantom.tissue_lengths_um(visible=True).sum()
    assert visible == pytest.approx(full, rel=1e-12) and full > 0
    truth = phantom.truth()
    assert truth["packing"] == "tessellation" and truth["axes_inside_own_cell"] == pytest.approx(1.0, rel=1e-12)


def test_fraction_and_sizes(phantom):
    vf = phantom.volume_fractions()
    assert abs(vf["smc_tissue"] - TESSELLATED.smc_fraction) < 0.005
    assert abs(vf["cavity_total"] - TESSELLATED.cavity_fraction) < 1e-3
    assert np.all(phantom.components[phantom.cell_ids > 0] == SMC)
    sizes = np.bincount(phantom.cell_ids.ravel())[1:]
    assert sizes.min() > 0  # every cell kept has voxels
    # as thick as the nominal spindles on average: SMC volume per um of axis in tissue = 2 pi b^2 / 3 (18.85 um^2),
    # to 10 % (the last round of random packing overshoots the length needed by a few axes)
    spindle = 2 * np.pi * TESSELLATED.cell_radius_um**2 / 3
    assert sizes.sum() / phantom.tissue_lengths_um().sum() == pytest.approx(spindle, rel=0.10)
    assert phantom.lengths_um.max() <= TESSELLATED.cell_length_um + 1e-9


def test_axes_keep_their_distance(phantom):
    seg = phantom.segments_um
    p, d = seg[:, 0], seg[:, 1] - seg[:, 0]
    gaps = [segment_distances(p[k], d[k], np.delete(p, k, 0), np.delete(d, k, 0)).min() for k in range(len(p))]
    assert min(gaps) >= TESSELLATED.min_axis_gap_um - 1e-9


def test_same_seed_same_phantom():
    a, b = make_phantom(TESSELLATED, rng=11), make_phantom(TESSELLATED, rng=11)
    assert np.array_equal(a.cell_ids, b.cell_ids) and np.array_equal(a.segments_um, b.segments_um)

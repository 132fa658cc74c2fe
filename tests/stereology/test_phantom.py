"""Synthetic tissue phantom: composition targets, truth bookkeeping, Watson axes, bad input."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.stereology.micrographs.geometry import clip_segment_to_box, sample_watson_axes
from bayestissue.stereology.micrographs.phantom import (
    CAVITY,
    ECM,
    SMC,
    PhantomOptions,
    TissuePhantom,
    make_phantom,
)

SMALL = PhantomOptions(extent_um=(30.0, 60.0, 60.0))


@pytest.fixture(scope="module")
def small():
    return make_phantom(SMALL, rng=3)


def test_fractions_hit_targets(small):
    vf = small.volume_fractions()
    assert vf["cavity_total"] == pytest.approx(1 / 3, abs=1e-4)  # exact voxel quantile
    # placement stops at the first cell past the target: overshoot below one cell (~1400 um^3)
    tissue_um3 = (1 - vf["cavity_total"]) * small.volume_um3
    assert 0 <= vf["smc_tissue"] - 0.589 < 1400 / tissue_um3
    assert set(np.unique(small.components)) == {CAVITY, ECM, SMC}
    assert np.all((small.cell_ids > 0) == (small.components == SMC))


def test_other_targets_are_followed():
    p = make_phantom(PhantomOptions(extent_um=(30.0, 60.0, 60.0), smc_fraction=0.4,
                                    cavity_fraction=0.2), rng=1)  # fmt: skip
    vf = p.volume_fractions()
    assert vf["cavity_total"] == pytest.approx(0.2, abs=1e-4)
    assert vf["smc_tissue"] == pytest.approx(0.4, abs=0.03)


def test_same_seed_same_phantom_and_truth(small):
    again = make_phantom(SMALL, rng=3)
    assert np.array_equal(again.components, small.components)
    assert np.array_equal(again.segments_um, small.segments_um)
    other = make_phantom(SMALL, rng=4)
    assert not np.array_equal(other.components, small.components)
    t = small.truth()
    assert t["synthetic"] is True and t["seed"] == 3
    assert t["n_cells"] == len(t["cells"]) == len(small.segments_um)
    assert t["length_density_per_um2"] == pytest.approx(small.length_density())


def test_cell_axes_follow_the_mixture(small):
    axes = np.array(SMALL.axes)
    cosines = np.abs(small.directions @ axes.T)
    own = cosines[np.arange(len(cosines)), small.component_of]
    # kappa = 20: E[cos^2] = 0.95, so most cells lie within 25 degrees of their own axis
    assert np.median(np.degrees(np.arccos(np.clip(own, 0, 1)))) < 15
    lengths = small.lengths_um
    assert np.all(lengths <= SMALL.cell_length_um + 1e-9) and np.all(lengths > 0)


def _mean_t2(kappa):
    t = np.linspace(0, 1, 20001)
    w = np.exp(kappa * (t**2 - 1))
    return np.trapezoid(t**2 * w, t) / np.trapezoid(w, t)


@pytest.mark.parametrize("kappa", [2.0, 20.0])
def test_watson_sampler_matches_the_moment(kappa):
    mode = np.array([0.0, 0.6, 0.8])
    x = sample_watson_axes(mode, kappa, 20000, rng=0)
    assert np.allclose(np.linalg.norm(x, axis=1), 1)
    t2 = (x @ mode) ** 2
    se = t2.std() / np.sqrt(len(t2))
    assert abs(t2.mean() - _mean_t2(kappa)) < 4 * se
    assert abs(t2.mean() - _mean_t2(2 * kappa)) > 4 * se  # negative control: wrong kappa


def test_clip_segment_to_box():
    seg = clip_segment_to_box([-5, 5, 5], [15, 5, 5], [10, 10, 10])
    assert np.allclose(seg, [[0, 5, 5], [10, 5, 5]])
    assert clip_segment_to_box([-5, 20, 5], [15, 20, 5], [10, 10, 10]) is None
    inside = clip_segment_to_box([1, 1, 1], [2, 3, 4], [10, 10, 10])
    assert np.allclose(inside, [[1, 1, 1], [2, 3, 4]])


def test_tissue_length_excludes_sinuses_and_respects_the_box():
    comp = np.full((10, 10, 10), ECM, dtype=np.uint8)
    comp[:, :, 5:] = CAVITY  # x >= 5 um is a sinus
    p = TissuePhantom(
        components=comp,
        cell_ids=np.zeros_like(comp, dtype=np.int32),
        voxel_um=1.0,
        segments_um=np.array([[[0.0, 5.0, 5.0], [10.0, 5.0, 5.0]]]),
        directions=np.array([[1.0, 0, 0]]),
        component_of=np.array([0]),
        options=PhantomOptions(extent_um=(10.0, 10.0, 10.0)),
    )
    assert p.tissue_lengths_um() == pytest.approx([5.0], abs=0.1)
    assert p.length_density() == pytest.approx(5.0 / 1000, rel=0.02)
    box = ((0, 2.5), (0, 10), (0, 10))
    assert p.length_density(box) == pytest.approx(2.5 / 250, rel=0.02)


def test_visible_length_skips_the_axis_inside_another_cell():
    """Two cells along x at y = z = 5: cell 2's axis (x 0-10) runs through cell 1's voxels for x < 4;
    its visible length is 6 um, its full length 10; cell 1 (x 0-4) is all visible."""
    comp = np.full((10, 10, 10), SMC, dtype=np.uint8)
    ids = np.full(comp.shape, 2, dtype=np.int32)
    ids[:, :, :4] = 1
    p = TissuePhantom(
        components=comp,
        cell_ids=ids,
        voxel_um=1.0,
        segments_um=np.array([[[0.0, 5.0, 5.0], [4.0, 5.0, 5.0]], [[0.0, 5.0, 5.0], [10.0, 5.0, 5.0]]]),
        directions=np.array([[1.0, 0, 0], [1.0, 0, 0]]),
        component_of=np.array([0, 0]),
        options=PhantomOptions(extent_um=(10.0, 10.0, 10.0)),
    )
    assert p.tissue_lengths_um() == pytest.approx([4.0, 10.0], abs=0.1)
    assert p.tissue_lengths_um(visible=True) == pytest.approx([4.0, 6.0], abs=0.1)
    assert p.length_density(visible=True) == pytest.approx(10.0 / 1000, rel=0.02)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"extent_um": (-1.0, 10.0, 10.0)}, "extent_um: expected three positive"),
        ({"extent_um": (2.0, 10.0, 10.0)}, "at least 4 voxels"),
        ({"smc_fraction": 1.5}, "smc_fraction: expected a number in"),
        ({"weights": (0.5, 0.5, 0.5)}, "weights: expected non-negative weights summing to 1"),
        ({"axes": ((1.0, 1.0, 0.0),) * 3}, r"axes\[0\]: expected a unit vector"),
        ({"cell_radius_um": 40.0}, "cell_radius_um"),
        ({"cavity_scale_um": (1.0, 2.0)}, "cavity_scale_um: expected three positive"),
        ({"max_attempts": 0}, "max_attempts: expected a positive integer or None"),
    ],
)
def test_bad_options_are_named(kwargs, match):
    with pytest.raises(ValidationError, match=match):
        PhantomOptions(**kwargs)


def test_unreachable_density_is_reported():
    opts = PhantomOptions(extent_um=(20.0, 40.0, 40.0), packing="overlap", max_overlap=0.0, max_attempts=300)
    with pytest.raises(ValidationError, match="smc_fraction: expected a density reachable"):
        make_phantom(opts, rng=0)
    # the tessellation cannot fill more than the tissue its seams leave
    with pytest.raises(ValidationError, match="smc_fraction: expected a fraction the tessellation reaches"):
        make_phantom(PhantomOptions(extent_um=(20.0, 40.0, 40.0), smc_fraction=0.97), rng=0)

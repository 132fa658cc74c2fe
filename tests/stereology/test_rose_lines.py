"""Line systems, L_V, hemisphere conventions, the equal-area rose and the Lambert projection."""

import numpy as np
import pytest
from scipy import stats

from bayestissue._validation import ValidationError
from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology.axial import WatsonMixture, axial_angle
from bayestissue.stereology.lines import (
    LineSystem,
    azimuth_elevation,
    length_density,
    segments_from_polylines,
    stack_volume,
    to_upper_hemisphere,
    unit_vector,
)
from bayestissue.stereology.rose import (
    cell_index,
    directions_vs_n,
    lambert_project,
    lambert_ring_radii,
    preferential_directions,
    rose_of_directions,
)


def _uniform_axes(n, rng):
    x = rng.normal(size=(n, 3))
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def test_paper_length_density():
    # paper Section 3.1: 3171.1 um in 184 774 um^3 -> 0.0172 um^-2
    assert length_density(3171.1, 184774.0) == pytest.approx(0.0172, abs=5e-5)
    assert stack_volume(10.0, 20.0, 10, 5.0) == 10000.0
    with pytest.raises(ValidationError, match="volume_um3"):
        length_density(1.0, 0.0)
    with pytest.raises(ValidationError, match="n_sections"):
        stack_volume(1.0, 1.0, 0, 5.0)


def test_hemisphere_and_angles_of_paper_vectors():
    az, el = azimuth_elevation(PAPER_DIRECTIONS)
    # all three on the equator (pole = z): elevations zero
    np.testing.assert_allclose(el, 0.0, atol=1e-12)
    # v1 = y: 90 deg; v2: 20 deg; v3 = (0.9369, -0.342, 0) ~ (-0.9369, 0.342, 0) with y > 0: 160 deg
    np.testing.assert_allclose(az, [90.0, 20.05, 159.95], atol=0.02)
    u = to_upper_hemisphere([[0, 0, -1.0], [1.0, -1.0, 0.0], [-1.0, 0, 0]])
    np.testing.assert_allclose(u, [[0, 0, 1], [-np.sqrt(0.5), np.sqrt(0.5), 0], [1, 0, 0]])
    np.testing.assert_allclose(unit_vector(az, el), to_upper_hemisphere(PAPER_DIRECTIONS), atol=1e-12)


def test_line_system():
    start, end, cell = segments_from_polylines(
        [np.array([[0, 0, 0], [3, 4, 0], [3, 4, 12.0]]), np.array([[1, 1, 1], [1, 1, 2.0]])], [7, 8]
    )
    ls = LineSystem(start, end, cell, volume_um3=100.0)
    np.testing.assert_allclose(ls.lengths, [5, 12, 1])
    assert ls.total_length_um == 18 and ls.n_cells == 2
    assert ls.length_density() == pytest.approx(0.18)
    np.testing.assert_allclose(ls.directions[1], [0, 0, 1])
    assert len(ls.subset([0, 0, 2]).cell) == 3


def test_line_system_bad_inputs():
    s = np.zeros((2, 3))
    e = np.array([[1.0, 0, 0], [0, 0, 0]])
    with pytest.raises(ValidationError, match="segments of positive length"):
        LineSystem(s, e, [1, 2])
    with pytest.raises(ValidationError, match="one id per segment"):
        LineSystem(s, e + 1, [1])
    with pytest.raises(ValidationError, match="probed volume"):
        LineSystem(s, e + 1, [1, 2]).length_density()
    with pytest.raises(ValidationError, match="\\(k >= 2, 3\\) vertices"):
        segments_from_polylines([np.zeros((1, 3))], [1])


def test_lambert_ring_radii():
    for n in (6, 8, 15):
        r = lambert_ring_radii(n)
        np.testing.assert_allclose(r, np.sqrt(2 * np.arange(n + 1) / n))
        # the band boundaries cos(theta_k) = 1 - k/n project onto these radii
        z = 1 - np.arange(n + 1) / n
        d = np.stack([np.sqrt(1 - z**2), np.zeros_like(z), z], axis=1)
        np.testing.assert_allclose(np.linalg.norm(lambert_project(d), axis=1), r, atol=1e-12)
    assert np.linalg.norm(lambert_project([[0, 1.0, 0]])) == pytest.approx(np.sqrt(2))


def test_uniform_axes_fill_equal_area_cells_equally():
    rng = np.random.default_rng(0)
    for n in (8, 15):
        rose = rose_of_directions(_uniform_axes(60 * n * n, rng), n=n)
        counts = rose.lengths.ravel()
        p = stats.chisquare(counts).pvalue
        assert p > 1e-3
    # negative control: cells of equal angular height (not equal area) are not filled equally
    x = _uniform_axes(20000, rng)
    _, el = azimuth_elevation(x)
    naive = np.bincount(np.minimum((el / 90 * 8).astype(int), 7), minlength=8)
    assert stats.chisquare(naive).pvalue < 1e-10


def test_cell_index_known_values():
    band, mer = cell_index([[0, 0, 1.0], [1.0, 0.01, 0.0], [0, -1.0, 0.0]], 8)
    assert band.tolist() == [7, 0, 0]
    assert mer.tolist() == [7 - 7, 0, 2]  # (0, -1, 0) ~ (0, 1, 0): azimuth 90 -> meridian 2 of 8
    with pytest.raises(ValidationError, match="an integer >= 1"):
        cell_index([[0, 0, 1.0]], 0)


def test_preferential_directions_on_watson_sample():
    mix = WatsonMixture(PAPER_DIRECTIONS, [30.0, 30.0, 30.0], [0.5, 0.25, 0.25])
    x, _ = mix.sample(3000, rng=1)
    lengths = np.random.default_rng(2).uniform(1, 10, len(x))
    res = directions_vs_n(x, lengths, ns=(8, 15))
    for _n, tops in res.items():
        vec = np.array([c["vector"] for c in tops])
        # each paper direction is matched by one of the three (principal axes, not cell centres)
        ang = axial_angle(vec[:, None, :], PAPER_DIRECTIONS[None])
        assert np.all(ang.min(axis=0) < 6.0)
        assert tops[0]["share"] > tops[1]["share"]
        assert np.all(np.abs([c["elevation"] for c in tops]) < 8)
    # literal top cells (no merging) repeat the equatorial v1 mode split into antipodal cells
    lit = preferential_directions(rose_of_directions(x, lengths, n=15), merge_deg=0.0)
    vec = np.array([c["vector"] for c in lit])
    ang_v1 = axial_angle(vec, PAPER_DIRECTIONS[0])
    assert np.sum(ang_v1 < 15) >= 2

"""Point-grid counting: known fractions, grid geometry, the table format, bad input."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.io.stereology_files import read_point_counts
from bayestissue.stereology.micrographs.gridcount import COMPONENTS, count_points, grid_points, write_grid_counts
from bayestissue.stereology.micrographs.phantom import CAVITY, ECM, SMC


def _halves(n=6, H=200, W=200):
    lab = np.full((n, H, W), ECM, dtype=np.uint8)
    lab[:, :, : W // 4] = CAVITY  # a quarter cavity
    lab[:, : H // 2, W // 4 :] = SMC  # half of the rest SMC
    return lab


def test_grid_geometry():
    pts = grid_points((100, 80), 10.0, rng=0)
    assert len(pts) == 80
    assert np.all(pts[:, 0] < 100) and np.all(pts[:, 1] < 80)
    d = np.diff(np.unique(pts[:, 0]))
    assert np.allclose(d, 10.0)
    offs = np.array([grid_points((100, 80), 10.0, rng=k)[0] for k in range(200)])
    assert offs.min() >= 0 and offs.max() < 10 and offs.std() > 2  # uniform offsets
    valid = np.zeros((100, 80), bool)
    valid[:50] = True
    assert np.all(grid_points((100, 80), 10.0, valid=valid, rng=0)[:, 0] < 50)


def test_counts_estimate_the_known_fractions():
    g = count_points(_halves(), spacing_px=7.3, rng=1)
    vf = g.volume_fractions()
    assert vf["smc_tissue"] == pytest.approx(0.5, abs=0.03)
    assert vf["cavity_total"] == pytest.approx(0.25, abs=0.03)
    assert g.counts.shape == (6, 3) and np.array_equal(g.section, np.arange(6))
    assert np.array_equal(g.column("smc"), g.counts[:, SMC])


def test_table_round_trip(tmp_path):
    g = count_points(_halves(), spacing_px=8.0, sections=[1, 3, 5], rng=2)
    p = write_grid_counts(tmp_path / "pc.csv", g, pixel_um=0.5, meta={"synthetic": "yes"})
    d = read_point_counts(p)
    assert d["grid_spacing_um"] == pytest.approx(4.0)
    assert d["components"] == COMPONENTS and d["excluded"] == ("cavity",)
    assert np.array_equal(d["section"], [1, 3, 5])
    assert np.array_equal(d["counts"], g.counts)


def test_bad_counting_input():
    lab = _halves()
    with pytest.raises(ValidationError, match="grid_spacing: expected less than the image"):
        count_points(lab, spacing_px=500)
    with pytest.raises(ValidationError, match="grid_spacing: expected a number > 0"):
        count_points(lab, spacing_px=0)
    with pytest.raises(ValidationError, match=r"sections: expected indices in \[0, 5\]"):
        count_points(lab, spacing_px=10, sections=[7])
    with pytest.raises(ValidationError, match="labels: expected a segmented stack"):
        count_points(lab[0], spacing_px=10)
    cav = np.zeros_like(lab)
    with pytest.raises(ValidationError, match="point counts: expected SMC or ECM points"):
        count_points(cav, spacing_px=10).volume_fractions()

"""Stereology file formats (round trips, bad files) and the ``bayestissue stereology`` CLI."""

import re

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.cli import main
from bayestissue.io.stereology_files import (
    REPLICATE_COLUMNS,
    read_line_system,
    read_point_counts,
    read_replicates,
    write_line_system,
    write_point_counts,
    write_replicates,
)
from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology.axial import WatsonMixture
from bayestissue.stereology.lines import LineSystem
from bayestissue.stereology.point_counts import PointCounts


@pytest.fixture
def files(tmp_path):
    rng = np.random.default_rng(0)
    n = 12
    P = rng.integers(250, 320, n)
    Q = np.round(P * 0.59).astype(int)
    counts = np.c_[Q, P - Q, 400 - P]
    cpath = write_point_counts(
        tmp_path / "counts.csv",
        np.arange(2, 72, 6),
        counts,
        ("smc", "ecm", "other"),
        meta={"synthetic": "yes -- test", "excluded": "other"},
    )
    mix = WatsonMixture(PAPER_DIRECTIONS, [30.0, 30.0, 30.0], [0.45, 0.3, 0.25])
    d, _ = mix.sample(150, rng=rng)
    start = rng.random((150, 3)) * 50
    lpath = write_line_system(
        tmp_path / "lines.csv",
        start,
        start + 8 * d,
        np.repeat(np.arange(50), 3),
        sidecar={"extent_x_um": 10.0, "extent_y_um": 20.0, "n_sections": 10, "section_thickness_um": 5.0},
        meta={"synthetic": "yes -- test"},
    )
    return cpath, lpath, counts


def test_point_count_round_trip(files):
    cpath, _, counts = files
    d = read_point_counts(cpath)
    assert d["components"] == ("smc", "ecm", "other") and d["excluded"] == ("other",)
    np.testing.assert_array_equal(d["counts"], counts)
    pc = PointCounts.from_file(cpath)
    assert pc.reference_components == ("smc", "ecm")


def test_line_system_round_trip_and_sidecar(files):
    _, lpath, _ = files
    d = read_line_system(lpath)
    assert d["volume_um3"] == pytest.approx(10.0 * 20.0 * 10 * 5.0)  # from the extent in the sidecar
    ls = LineSystem.from_file(lpath)
    assert ls.n_cells == 50 and ls.length_density() == pytest.approx(ls.total_length_um / 10000.0)


def test_bad_files(tmp_path):
    p = tmp_path / "c.csv"
    p.write_text("section,smc,ecm\n0,1,2\n")
    with pytest.raises(ValidationError, match="'<component>_points' column"):
        read_point_counts(p)
    p.write_text("section,smc_points,ecm_points\n0,1,-2\n6,3,4\n12,1,1\n")
    with pytest.raises(
        ValidationError,
        match=r"data row 1 column ecm_points: expected a whole number of points in \[0, 1e\+07\], got -2.0",
    ):
        PointCounts.from_file(p)
    p.write_text("# excluded: cavity\nsection,smc_points,ecm_points\n0,1,2\n")
    with pytest.raises(ValidationError, match="excluded: expected one of"):
        PointCounts.from_file(p)
    q = tmp_path / "l.csv"
    q.write_text("cell,x0_um,y0_um,z0_um,x1_um,y1_um,z1_um\n1,0,0,0,0,0,0\n")
    with pytest.raises(ValidationError, match="segments of positive length"):
        LineSystem.from_file(q)
    with pytest.raises(FileNotFoundError):
        read_line_system(tmp_path / "missing.csv")


def test_replicates_round_trip_and_checks(tmp_path):
    B = 5
    cols = {"replicate": np.arange(1, B + 1), "phi_smc": np.full(B, 0.6), "phi_ecm": np.full(B, 0.4)}
    cols["phi_matrix"] = cols["phi_ecm"]
    for k in (1, 2, 3):
        cols[f"phi_fibre{k}"] = np.full(B, 0.2)
        for j, c in enumerate("xyz"):
            cols[f"v{k}_{c}"] = np.full(B, PAPER_DIRECTIONS[k - 1, j])
    path = write_replicates(tmp_path / "r.csv", cols, meta={"split": "paper"})
    r = read_replicates(path)
    assert r["phi_matrix"].shape == (B,) and r["phi_fibres"].shape == (B, 3)
    assert r["directions"].shape == (B, 3, 3) and r["split"] == "paper"
    np.testing.assert_allclose(r["directions"][0], PAPER_DIRECTIONS, atol=1e-9)
    cols["v2_x"] = np.full(B, 2.0)
    write_replicates(tmp_path / "bad.csv", cols)
    with pytest.raises(ValidationError, match="v2 of replicate row 1: expected a unit vector"):
        read_replicates(tmp_path / "bad.csv")
    with pytest.raises(ValidationError, match="replicate columns"):
        write_replicates(tmp_path / "x.csv", {"phi_smc": cols["phi_smc"]})
    assert REPLICATE_COLUMNS[:4] == ("replicate", "phi_smc", "phi_ecm", "phi_matrix")


def test_cli_commands(files, tmp_path, capsys):
    cpath, lpath, _ = files
    assert main(["stereology", "surs", "--n-sections", "72", "--period", "6", "--seed", "3"]) == 0
    assert len(capsys.readouterr().out.split()) == 12
    assert main(["stereology", "fractions", str(cpath)]) == 0
    assert "CE_m1" in capsys.readouterr().out
    assert main(["stereology", "lines", str(lpath)]) == 0
    assert "L_V" in capsys.readouterr().out
    assert main(["stereology", "lines", str(lpath), "--uniform-background"]) == 0
    assert re.search(r"uniform background weight 0\.\d{3}\)", capsys.readouterr().out)
    out_rose = tmp_path / "rose.csv"
    assert main(["stereology", "rose", str(lpath), "--n", "8", "15", "--out", str(out_rose)]) == 0
    assert out_rose.is_file()
    out = tmp_path / "R.csv"
    args = ["stereology", "replicates", str(cpath), str(lpath), "--n-boot", "10", "--split", "length"]
    assert main([*args, "--out", str(out)]) == 0
    r = read_replicates(out)
    assert r["directions"].shape == (10, 3, 3)
    assert "synthetic" in r["meta"]


def test_cli_bad_input_exits_2(tmp_path, capsys):
    p = tmp_path / "neg.csv"
    p.write_text("section,smc_points,ecm_points\n0,1,-2\n6,3,4\n12,1,1\n")
    assert main(["stereology", "fractions", str(p)]) == 2
    assert "neg.csv data row 1 column ecm_points: expected a whole number of points" in capsys.readouterr().err
    assert main(["stereology", "fractions", str(tmp_path / "none.csv")]) == 2

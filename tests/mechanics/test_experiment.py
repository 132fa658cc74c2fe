"""Experiment files and tissue inputs: loading, and a clear message for each kind of bad input."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.mechanics import (
    PAPER_TISSUE,
    TissueConfig,
    check_parameters,
    load_experiment,
    param_names,
    parse_parameters,
    simulate,
)

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture
def t1(tmp_path):
    shutil.copy(DATA / "T1.csv", tmp_path / "T1.csv")
    toml = (DATA / "T1.toml").read_text()
    return tmp_path, toml


def write(tmp, text, name="exp.toml"):
    p = tmp / name
    p.write_text(text)
    return p


def test_bundled_experiments_load():
    e1 = load_experiment(DATA / "T1.toml")
    e2 = load_experiment(DATA / "T2.toml")
    assert (e1.time_s.size, e1.n_steps, e1.dt_s) == (401, 200, 6.0)
    assert (e2.time_s.size, e2.n_steps) == (143, 142)
    assert e1.synthetic and e1.noise_sd_mm == 0.02
    assert e1.protocol.kind == "creep" and e2.protocol.kind == "ramp"
    np.testing.assert_allclose(e1.area_mm2, 2.43 * 3.9)


@pytest.mark.parametrize(
    "old, new, match",
    [
        (
            "length_y_mm = 2.43",
            "",
            r"specimen.length_y_mm: expected a value for 'length_y_mm', got 'missing'",
        ),
        (
            "length_y_mm = 2.43",
            "length_y_mm = -2.43",
            r"\[specimen\] length_y_mm: expected a number > 0, got -2.43",
        ),
        (
            "length_x_mm = 5.33",
            "length_x_mm = 0",
            r"\[specimen\] length_x_mm: expected a number > 0, got 0",
        ),
        (
            'kind = "creep"',
            'kind = "relax"',
            r"\[protocol\] kind: expected one of \['creep', 'ramp', 'measured', 'stretch_ramp'",
        ),
        ("stress_kpa = 10.6", "", r"protocol.stress_kpa: expected a value for 'stress_kpa'"),
        ("dt_s = 6.0", "dt_s = 0", r"\[simulation\] dt_s: expected a number > 0, got 0"),
        (
            "[simulation]\ndt_s = 6.0",
            "",
            r"\[simulation\]: expected a \[simulation\] table, got 'missing'",
        ),
    ],
)
def test_bad_experiment_fields(t1, old, new, match):
    tmp, toml = t1
    assert old in toml
    with pytest.raises(ValidationError, match=match):
        load_experiment(write(tmp, toml.replace(old, new)))


@pytest.mark.parametrize(
    "tissue, match",
    [
        (
            "phi_matrix = 0.5",
            r"tissue volume fractions: expected a sum of 1 \(within 1e-6\), got 'phi_matrix \+ ",
        ),
        (
            "directions = [[0, 0, 0], [1, 0, 0], [0, 0, 1]]",
            r"tissue.directions\[0\]: expected a unit vector",
        ),
        (
            "directions = [[0, 2, 0], [1, 0, 0], [0, 0, 1]]",
            r"tissue.directions\[0\]: expected a unit vector .*2",
        ),
        ("phi_fibres = [0.2, 0.2]", r"tissue.phi_fibres: expected 3 values"),
        ("bulk_kpa = -5", r"\[tissue\] bulk_kpa: expected a number > 0, got -5"),
    ],
)
def test_bad_tissue(t1, tissue, match):
    tmp, toml = t1
    with pytest.raises(ValidationError, match=match):
        load_experiment(write(tmp, toml + "\n[tissue]\n" + tissue + "\n"))


@pytest.mark.parametrize(
    "row, match",
    [
        (
            "6,nan,100",
            r"T1.csv line \d+ column displacement_mm: expected a finite number \(decimal point\), got 'nan'",
        ),
        (
            "2,1.1,100",
            r"time_s: expected strictly increasing values, got '3.0 then 2.0 at rows 1-2'",
        ),
        ("nan,1.1,100", r"T1.csv line \d+ column time_s: expected a finite number \(decimal point\), got 'nan'"),
    ],
)
def test_bad_data_columns(t1, row, match):
    tmp, toml = t1
    lines = (tmp / "T1.csv").read_text().splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith("6,"))
    lines[k] = row
    (tmp / "T1.csv").write_text("\n".join(lines))
    with pytest.raises(ValidationError, match=match):
        load_experiment(write(tmp, toml))


def test_missing_files(t1, tmp_path):
    with pytest.raises(FileNotFoundError, match="experiment file .* does not exist"):
        load_experiment(tmp_path / "nope.toml")
    tmp, toml = t1
    with pytest.raises(FileNotFoundError, match="table file .*other.csv' does not exist"):
        load_experiment(write(tmp, toml.replace('file = "T1.csv"', 'file = "other.csv"')))


def test_measured_protocol_takes_force_column(t1):
    tmp, toml = t1
    exp = load_experiment(write(tmp, toml.replace('kind = "creep"\nstress_kpa = 10.6', 'kind = "measured"')))
    np.testing.assert_allclose(exp.nominal_stress_kpa()[1:], 10.6, rtol=1e-6)
    csv = (tmp / "T1.csv").read_text().replace(",force_mN", ",load_mN")
    (tmp / "T1.csv").write_text(csv)
    with pytest.raises(
        ValidationError,
        match="protocol.kind: expected a data file with columns time_s and force_mN",
    ):
        load_experiment(write(tmp, toml.replace('kind = "creep"\nstress_kpa = 10.6', 'kind = "measured"')))


@pytest.mark.parametrize(
    "name, value, match",
    [
        ("mu", -1.0, r"mu: expected a modulus >= 0 \(kPa\), got -1.0"),
        ("ginf2", -3.0, r"ginf2: expected a modulus >= 0 \(kPa\), got -3.0"),
        ("gamma1", 1.0, r"gamma1: expected a value in \[0, 1\), got 1.0"),
        ("gamma3", -0.1, r"gamma3: expected a value in \[0, 1\), got -0.1"),
        ("beta2", 0.0, r"beta2: expected a rate > 0 \(1/s\), got 0.0"),
        ("beta1", np.nan, r"beta1: expected a rate > 0 \(1/s\), got nan"),
    ],
)
def test_bad_parameter_values(name, value, match):
    names = param_names(3)
    p = np.ones(11) * 0.5
    p[names.index(name)] = value
    with pytest.raises(ValidationError, match=match):
        check_parameters(p, PAPER_TISSUE.parameters)
    with pytest.raises(ValidationError, match=r"params\[1\]\." + match):
        check_parameters(np.vstack([np.full(11, 0.5), p]), PAPER_TISSUE.parameters)


def test_parse_parameters():
    p = parse_parameters("mu=2, beta3=0.01", PAPER_TISSUE.parameters)
    assert p[0] == 2 and p[10] == 0.01 and p[1] == 50
    with pytest.raises(ValidationError, match="--params: expected one of the parameter names mu, kappa"):
        parse_parameters("nu=2", PAPER_TISSUE.parameters)
    with pytest.raises(ValidationError, match="--params: expected name=value pairs"):
        parse_parameters("mu:2", PAPER_TISSUE.parameters)
    with pytest.raises(ValidationError, match="--params mu: expected a number, got 'abc'"):
        parse_parameters("mu=abc", PAPER_TISSUE.parameters)


def test_tissue_defaults_are_the_papers():
    assert PAPER_TISSUE.n_fibres == 3
    np.testing.assert_allclose(np.linalg.norm(PAPER_TISSUE.directions, axis=1), 1.0)
    np.testing.assert_allclose(PAPER_TISSUE.phi_fibres, [0.2, 0.2, 0.2])
    t = TissueConfig(directions=[[1, 0, 0]], phi_fibres=[0.3], phi_matrix=0.7)
    assert t.param_names == ("mu", "kappa", "ginf1", "gamma1", "beta1")


def test_invalid_toml_names_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[specimen\nlength_x_mm = 5")
    with pytest.raises(ValidationError, match="experiment bad.toml: expected valid TOML"):
        load_experiment(bad)


BIAXIAL_TOML = """name = "skin_biaxial"
synthetic = true
[specimen]
length_x_mm = 10.0
length_y_mm = 10.0
length_z_mm = 1.0
[protocol]
kind = "measured_stretch"
mode = "biaxial"
{extra}
[simulation]
dt_s = 0.5
[tissue]
preset = "rubber"
matrix = "neo_hookean"
[data]
file = "b.csv"
"""


@pytest.mark.parametrize(("extra", "second"), [("", "stretch_2"), ('stretch_2_column = "lam_y"', "lam_y")])
def test_biaxial_file_with_two_stretch_histories(tmp_path, extra, second):
    """A biaxial experiment file whose data give each face its own stretch (a stretch_2 column, or one named by
    stretch_2_column): the second face follows its own history, not the ratio; both faces' forces are observed."""
    t = np.arange(0.0, 10.5, 0.5)
    lam1, lam2 = np.interp(t, [0, 5, 10], [1, 1.2, 1.2]), np.interp(t, [0, 5, 10], [1, 1, 1.1])
    rows = "\n".join(f"{a},{b},{c},0,0" for a, b, c in zip(t, lam1, lam2, strict=True))
    (tmp_path / "b.csv").write_text(f"time_s,stretch,{second},force_mN,force_2_mN\n{rows}\n")
    (tmp_path / "b.toml").write_text(BIAXIAL_TOML.format(extra=extra))
    exp = load_experiment(tmp_path / "b.toml")
    np.testing.assert_allclose(exp.prescribed()[:, 1], np.interp(exp.step_time_s, t, lam2))
    assert [c.column for c in exp.channels] == ["force_mN", "force_2_mN"]
    y = simulate(exp, [200.0])
    assert y.shape == (t.size, 2) and np.all(np.isfinite(y))
    assert y[10, 1] > 0 and y[10, 1] < y[10, 0]  # face 2 held at 1 while face 1 is stretched: less force on it


def test_biaxial_file_naming_a_missing_second_column(tmp_path):
    (tmp_path / "b.csv").write_text("time_s,stretch,force_mN\n0,1,0\n1,1.1,0\n2,1.2,0\n")
    (tmp_path / "b.toml").write_text(BIAXIAL_TOML.format(extra='stretch_2_column = "lam_y"'))
    with pytest.raises(ValidationError, match=r"protocol.stretch_2_column: expected a column of the data file"):
        load_experiment(tmp_path / "b.toml")


def test_biaxial_file_with_two_force_histories(tmp_path):
    """kind = "measured", mode = "biaxial" with a force_2_mN column: each face carries its own dead load (nominal
    stress over its own reference area, 10 x 1 mm for both faces here); the displacements of both faces observed."""
    t = np.arange(0.0, 10.5, 0.5)
    f1, f2 = np.interp(t, [0, 5, 10], [0, 800, 800]), np.interp(t, [0, 5, 10], [0, 0, 500])
    rows = "\n".join(f"{a},{b},{c},0,0" for a, b, c in zip(t, f1, f2, strict=True))
    (tmp_path / "b.csv").write_text(f"time_s,force_mN,force_2_mN,displacement_mm,displacement_2_mm\n{rows}\n")
    toml = BIAXIAL_TOML.format(extra="").replace('kind = "measured_stretch"', 'kind = "measured"')
    (tmp_path / "b.toml").write_text(toml)
    exp = load_experiment(tmp_path / "b.toml")
    P = exp.prescribed()
    np.testing.assert_allclose(P[:, 1], np.interp(exp.step_time_s, t, f2) / 10.0)
    assert [c.column for c in exp.channels] == ["displacement_mm", "displacement_2_mm"]
    u = simulate(exp, [200.0])
    assert np.all(np.isfinite(u)) and u[10, 1] < 0 < u[10, 0]  # face 2 unloaded at 5 s: it contracts

"""Tissue presets: compositions, the boxes a calibration takes from them, overrides, and their generated docs."""

from pathlib import Path

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.mechanics import load_experiment
from bayestissue.mechanics.presets import PRESETS, presets_markdown
from bayestissue.workflows import config_from_mapping
from bayestissue.workflows.problem import build_problem

ROOT = Path(__file__).resolve().parents[2]


def test_reference_is_rendered_from_the_presets():
    assert (ROOT / "docs" / "presets.md").read_text() == presets_markdown()


def _experiment(tmp_path, tissue: str):
    (tmp_path / "x.toml").write_text(
        'name = "X"\n[specimen]\nlength_x_mm = 10\nlength_y_mm = 1\nlength_z_mm = 1\n'
        '[protocol]\nkind = "stretch_ramp"\nstretch = 1.05\nramp_s = 10\n[simulation]\ndt_s = 1\n'
        f"[data]\nduration_s = 20\nstep_s = 2\n[tissue]\n{tissue}\n"
    )
    return load_experiment(tmp_path / "x.toml")


def test_tendon_preset_composition_and_boxes(tmp_path):
    exp = _experiment(tmp_path, 'preset = "tendon"')
    assert exp.tissue.preset == "tendon" and exp.tissue.n_fibres == 1
    np.testing.assert_allclose(exp.tissue.directions, [[1, 0, 0]])
    assert exp.tissue.bulk_kpa == 2.0e6
    (tmp_path / "d.csv").write_text("time_s,force_mN\n" + "".join(f"{t},{t}\n" for t in range(1, 21)))
    text = (tmp_path / "x.toml").read_text().replace("duration_s = 20\nstep_s = 2", 'file = "d.csv"')
    (tmp_path / "x.toml").write_text(text)
    problem = build_problem([load_experiment(tmp_path / "x.toml")], config_from_mapping(None))
    specs = {s.name: s for s in problem.material.specs}
    assert (specs["ginf1"].lower, specs["ginf1"].upper) == PRESETS["tendon"].boxes["fibre modulus"]
    assert specs["ginf1"].value == pytest.approx(np.sqrt(1e2 * 1e7))
    assert (specs["gamma1"].lower, specs["gamma1"].upper) == (0.1, 0.95)
    bounded = build_problem(
        [load_experiment(tmp_path / "x.toml")], config_from_mapping(None, bounds={"ginf1": [1e3, 1e6]})
    )
    spec = next(s for s in bounded.material.specs if s.name == "ginf1")
    assert (spec.lower, spec.upper) == (1e3, 1e6)  # [parameters] bounds still override


def test_preset_values_are_overridden_by_keys(tmp_path):
    exp = _experiment(tmp_path, 'preset = "brain"\nbulk_kpa = 5000.0')
    assert exp.tissue.n_fibres == 0 and exp.tissue.bulk_kpa == 5000.0 and exp.tissue.preset == "brain"


def test_unknown_preset_is_refused(tmp_path):
    with pytest.raises(ValidationError, match=r"\[tissue\] preset: expected one of"):
        _experiment(tmp_path, 'preset = "kidney"')


def test_one_material_per_problem(tmp_path):
    a = load_experiment(ROOT / "data" / "measured" / "treloar_1944.toml")
    b = load_experiment(ROOT / "data" / "measured" / "budday_2017_basal_ganglia.toml")
    if a.tissue.preset == b.tissue.preset:
        pytest.skip("the bundled files share a preset")
    with pytest.raises(ValidationError, match="one preset"):
        build_problem([a, b], config_from_mapping(None))


def test_a_data_step_longer_than_the_duration_is_refused(tmp_path):
    """One row (t = 0) was simulated before (issue 34)."""
    from bayestissue._validation import ValidationError

    (tmp_path / "x.toml").write_text(
        'name = "X"\n[specimen]\nlength_x_mm = 10\nlength_y_mm = 1\nlength_z_mm = 1\n'
        '[protocol]\nkind = "stretch_ramp"\nstretch = 1.05\nramp_s = 10\n[simulation]\ndt_s = 1\n'
        "[data]\nduration_s = 20\nstep_s = 30\n"
    )
    with pytest.raises(ValidationError, match=r"data.step_s: expected a step at most data.duration_s \(20 s\), got 30"):
        load_experiment(tmp_path / "x.toml")

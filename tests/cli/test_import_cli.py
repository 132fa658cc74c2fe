"""bayestissue import: raw testing-machine exports in the documented shapes become experiments that load, simulate
and fit; what cannot be read is refused with the file, the line and what was expected (exit 2, nothing written)."""

import numpy as np
import pytest

from bayestissue.cli import main
from bayestissue.io.machine_export import read_machine_export
from bayestissue.mechanics import load_experiment, simulate

TENDON = """Specimen label,tendon_07
Diameter,2.1,mm
Gauge length (mm),25.0
Test date,2026-11-20

Time,Extension,Load,Strain
(s),(mm),(N),(%)
0.0,0.000,0.010,0
0.5,0.050,0.210,0.2
1.0,0.100,0.420,0.4
1.5,0.150,0.640,0.6
2.0,0.200,0.850,0.8
2.5,0.250,1.020,1.0
3.0,0.300,0.200,1.2
3.5,0.350,0.050,1.4
"""

#: semicolons, "key: value" metadata, width x thickness in cm, time in ms, force in kN, columns in another order
SKIN = """Sample: skin_3
Width (cm): 0.5
Thickness: 0.12
Gage length: 1.5 cm
Load;Time;Displacement
[kN];[ms];[mm]
0;0;0
0.001;1000;0.2
0.002;2000;0.4
0.0025;3000;0.6
"""


def _write(tmp_path, text, name="export.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_import_stretch_controlled(tmp_path, capsys):
    """Units converted (N -> mN), the round section turned into a square of the same area, the failure cut after the
    peak, the experiment loads as stretch-controlled with the force observed, and it simulates."""
    src = _write(tmp_path, TENDON)
    assert main(["import", str(src), "--out", str(tmp_path / "out"), "--tissue", "tendon"]) == 0
    assert "6 rows over 2.5 s" in capsys.readouterr().out
    exp = load_experiment(tmp_path / "out" / "tendon_07.toml")
    assert exp.controls == "stretch" and exp.observable[:2] == ("force", "mN")
    np.testing.assert_allclose(exp.force_mN, [10, 210, 420, 640, 850, 1020])
    np.testing.assert_allclose(exp.prescribed()[-1], 1 + 0.25 / 25.0)
    assert exp.area_mm2 == pytest.approx(np.pi * 2.1**2 / 4, rel=1e-12)
    assert exp.tissue.n_fibres == 1 and exp.tissue.preset == "tendon" and not exp.synthetic
    assert np.all(np.isfinite(simulate(exp, [10.0, 10.0, 1000.0, 0.5, 1.0])))


def test_import_force_controlled_other_shape(tmp_path):
    """Semicolons, 'key: value' metadata with units in the key or the value, ms, kN and cm, another column order;
    --control force makes the force the load and the displacement the observable."""
    src = _write(tmp_path, SKIN)
    code = main(["import", str(src), "--out", str(tmp_path), "--control", "force", "--step-s", "0.5", "--tissue",
                 "rubber", "--name", "skin"])  # fmt: skip
    assert code == 0
    exp = load_experiment(tmp_path / "skin.toml")
    assert exp.controls == "force" and exp.observable[:2] == ("displacement", "mm")
    np.testing.assert_allclose(exp.time_s, [0, 1, 2, 3])  # fewer samples than the step asks for: all kept
    np.testing.assert_allclose(exp.displacement_mm, [0, 0.2, 0.4, 0.6])
    np.testing.assert_allclose(exp.force_mN, [0, 1000, 2000, 2500])
    assert exp.specimen_mm == pytest.approx((15.0, 5.0, 0.12))


@pytest.mark.parametrize(
    "edit, message",
    [
        (("Time,Extension,Load,Strain", "Time,Stretchiness,Load,Strain"), "header row: expected a row naming a time"),
        (("(s),(mm),(N),(%)", "(s),(mm),(Pa),(%)"), "line 7 unit of 'Load': expected a force unit"),
        (("1.0,0.100,0.420", '1.0,"0,100",0.420'), "line 10 column 'Extension': expected a number"),
        (("1.5,0.150", "0.9,0.150"), "line 11 time: expected times increasing row by row"),
        (("Gauge length (mm),25.0\n", ""), "gauge length: expected a 'Gauge length' line or --gauge-mm"),
        (("Diameter,2.1,mm\n", ""), "cross-section: expected a 'Diameter' or 'Width' + 'Thickness' line"),
        (("Diameter,2.1,mm", "Diameter,2.1,furlong"), "line 2 diameter unit: expected a length unit"),
        (("Diameter,2.1,mm", "Diameter,-2.1,mm"), "line 2 diameter: expected a length > 0"),
    ],
)
def test_import_refusals(tmp_path, capsys, edit, message):
    src = _write(tmp_path, TENDON.replace(*edit))
    assert main(["import", str(src), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert message in err and "export.csv" in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_import_refuses_to_overwrite_and_bad_options(tmp_path, capsys):
    src = _write(tmp_path, TENDON)
    out = str(tmp_path / "out")
    assert main(["import", str(src), "--out", out]) == 0
    assert main(["import", str(src), "--out", out]) == 2
    assert "a new file name (or --overwrite)" in capsys.readouterr().err
    assert main(["import", str(src), "--out", out, "--overwrite"]) == 0
    assert main(["import", str(src), "--out", out, "--overwrite", "--drop", "1.5"]) == 2
    assert main(["import", str(src), "--out", out, "--overwrite", "--width-mm", "2"]) == 2
    assert "both or neither" in capsys.readouterr().err


@pytest.mark.parametrize("step", ["1000", "1.3"])
def test_a_resampling_step_longer_than_the_test_is_refused(tmp_path, capsys, step):
    """``--step-s 1000`` on a 3.5 s export: RuntimeWarnings and an error about a file the command had written and
    deleted (issue 34); a step leaving fewer than 2 steps over the 2.5 s kept (the failure at 3 s is cut) is refused
    before anything is written, naming the option, the file and the longest step allowed."""
    src = _write(tmp_path, TENDON)
    assert main(["import", str(src), "--out", str(tmp_path / "out"), "--step-s", step]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert "--step-s: expected a step of at most 1.25 s (export.csv keeps 2.5 s: at least 2 steps)" in err, err
    assert not (tmp_path / "out").exists()


def test_prepare_trims(tmp_path):
    from bayestissue.io.export_prepare import prepare

    export = read_machine_export(_write(tmp_path, TENDON))
    cols, notes = prepare(export)
    assert cols["force_mN"][-1] == pytest.approx(1020) and "samples from t = 3 s on are dropped" in notes[-1]
    assert "preload 10 mN at zero extension kept" in notes[0]
    cols, notes = prepare(export, drop=None)
    assert cols["time_s"].size == 8 and len(notes) == 1
    cols, notes = prepare(export, until_s=1.2, drop=None, tare=True)
    np.testing.assert_allclose(cols["time_s"], [0, 0.5, 1.0])
    np.testing.assert_allclose(cols["force_mN"], [0, 200, 410])
    assert "cut at t = 1.2 s" in notes[1] and "tare: subtracted the preload 10 mN" in notes[0]

"""`bayestissue simulate`: output, and exit status 2 with a one-line message (no traceback) on bad input."""

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bayestissue.cli import main
from bayestissue.io.tables import read_table
from bayestissue.mechanics import load_experiment, simulate
from bayestissue.paper import PAPER_PARAMETERS

DATA = Path(__file__).resolve().parents[2] / "data"


def test_simulate_writes_curve(tmp_path):
    out = tmp_path / "sim.csv"
    assert (
        main(
            [
                "simulate",
                str(DATA / "T1.toml"),
                "--preset",
                "T1",
                "--params",
                "mu=2.5",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    cols, meta = read_table(out, required=("time_s", "displacement_mm", "force_mN"))
    p = PAPER_PARAMETERS["T1"].copy()
    p[0] = 2.5
    exp = load_experiment(DATA / "T1.toml")
    np.testing.assert_allclose(cols["displacement_mm"], simulate(exp, p), rtol=1e-9)
    assert "mu=2.5" in meta["parameters"]
    # the force follows the load the model applies: full from the first data time on (t = 3 s lies inside the first
    # 6 s step, which carries the load), as in the data file -- not half of it, as a plain interpolation gave
    np.testing.assert_allclose(cols["force_mN"][1:], exp.force_mN[1:], rtol=1e-6)
    assert cols["force_mN"][0] == 0.0


def test_simulate_prints(capsys):
    assert main(["simulate", str(DATA / "T2.toml")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[3] == "time_s,displacement_mm,force_mN"
    assert len(out) == 4 + 143


@pytest.mark.parametrize(
    "args, message",
    [
        (["--params", "nu=1"], "--params: expected one of the parameter names"),
        (["--params", "gamma2=1.5"], "gamma2: expected a value in [0, 1), got 1.5"),
        (["--params", "beta1=-1"], "beta1: expected a rate > 0 (1/s), got -1.0"),
        # admissible values the model cannot be solved with (issue 34: exit 1 before, without the reason)
        (
            ["--params", "kappa=0,mu=0"],
            "--params: expected parameters the model can be solved with, got 'kappa=0,mu=0'",
        ),
    ],
)
def test_bad_params_exit_2_without_traceback(args, message):
    r = subprocess.run(
        [sys.executable, "-m", "bayestissue", "simulate", str(DATA / "T1.toml"), *args],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2
    assert message in r.stderr
    assert "Traceback" not in r.stderr


def test_missing_experiment_exit_2(capsys, tmp_path):
    assert main(["simulate", str(tmp_path / "none.toml")]) == 2
    assert "experiment file" in capsys.readouterr().err


def test_another_tissue_starts_from_its_preset(tmp_path, capsys):
    """A tendon experiment is simulated from the middle of the tendon preset's boxes (the fibre modulus about
    31.6 MPa, not the slug paper's kPa), and the slug paper's T1 set is refused for it."""
    exp = tmp_path / "tendon.toml"
    exp.write_text((DATA / "T1.toml").read_text().replace("[data]", '[tissue]\npreset = "tendon"\n\n[data]'))
    shutil.copy(DATA / "T1.csv", tmp_path / "T1.csv")
    assert main(["simulate", str(exp), "--out", str(tmp_path / "sim.csv")]) == 0
    assert "ginf1=31622.8" in (tmp_path / "sim.csv").read_text()
    assert main(["simulate", str(exp), "--preset", "T1"]) == 2
    assert "--preset: expected 'initial' for the tendon tissue of tendon.toml" in capsys.readouterr().err

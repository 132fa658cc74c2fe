"""Every shipped example configuration runs: the command in its header (experiments, config) through the CLI, with
--quick so that the suite stays short (the full runs' times: examples/README.md)."""

import shlex
from pathlib import Path

import pytest

from bayestissue.cli import main
from bayestissue.workflows import load_config

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))


def _command(path: Path) -> list[str]:
    """The ``bayestissue fit ...`` command written in the example's header, as arguments after ``fit``."""
    line = next(s for s in path.read_text().splitlines() if "bayestissue fit" in s)
    words = shlex.split(line.lstrip("# "))
    return words[words.index("fit") + 1 :]


def test_examples_exist():
    assert {p.stem for p in EXAMPLES} >= {"creep_T1", "ramp_T2", "joint_T1_T2", "quick_look"}


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs(path, tmp_path, capsys):
    load_config(path)  # valid against the schema
    args = _command(path)
    assert args[args.index("--config") + 1] == f"examples/{path.name}"
    experiments = [str(ROOT / a) for a in args[: args.index("--config")]]
    code = main(
        ["fit", *experiments, "--config", str(path), "--out", str(tmp_path / "run"), "--quick"]
        + ["--no-figures", "--no-progress"]
    )
    assert code == 0, capsys.readouterr().err
    assert (tmp_path / "run" / "posterior.nc").is_file()

"""bayestissue --quiet: no progress bar in any command."""

from pathlib import Path

from bayestissue.cli import main

DATA = Path(__file__).resolve().parents[2] / "data"


def _replicates(tmp_path, *flags):
    args = ["stereology", "replicates", str(DATA / "stereology_counts.csv"), str(DATA / "stereology_lines.csv"),
            "--n-boot", "4", "--out", str(tmp_path / "r.csv")]  # fmt: skip
    return main([*flags, *args])


def test_quiet_silences_the_progress_bars(tmp_path, capsys):
    assert _replicates(tmp_path) == 0
    assert "direction bootstrap" in capsys.readouterr().err
    (tmp_path / "r.csv").unlink()
    assert _replicates(tmp_path, "--quiet") == 0
    assert "direction bootstrap" not in capsys.readouterr().err
    assert (tmp_path / "r.csv").is_file()

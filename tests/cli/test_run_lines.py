"""cli.run_lines: the progress line of a long study stage's nested runs."""

from bayestissue.cli import run_lines


def test_the_line_names_the_run_and_calls_and_leaves_out_an_unknown_log_z(capsys):
    report = run_lines("[stage] T1 full", seconds=0.0)
    report(2, 150_000, 0.0, False, float("nan"))  # UltraNest's population step knows no log Z during the run
    report(0, 20_000, 310.0, True, 917.962)  # nautilus does
    assert capsys.readouterr().out.splitlines() == [
        "[stage] T1 full run 2: 150000 calls",
        "[stage] T1 full run 0: 20000 calls, log Z so far 917.962",
    ]


def test_lines_come_at_most_every_seconds(capsys):
    report = run_lines("[stage]", seconds=3600.0)
    report(0, 1, 0.0, False, 1.0)
    assert capsys.readouterr().out == ""

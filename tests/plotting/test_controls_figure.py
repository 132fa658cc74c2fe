"""The controls figure: tension per pair against the threshold, verdict counts per scenario."""

import matplotlib.pyplot as plt

from bayestissue.analyses.verdicts import ControlsVerdict, confusion, verdict_text
from bayestissue.plotting.controls import plot_controls


def _row(name, planted, q, different, named, kind):
    return name, planted, ControlsVerdict(Q=q, p=0.5, different=different, causes={}, named=named, kind=kind)


def test_counts_and_threshold_are_drawn():
    rows = [
        _row("none", (), 3.0, False, (), "no difference"),
        _row("none", (), 40.0, True, (3,), "named"),  # a false positive
        _row("stiff", (3,), 4e4, True, (3,), "named"),
        _row("stiff", (3,), 4e4, True, (2, 3), "indistinguishable"),
    ]
    table = confusion(rows)
    assert table["none"]["named"] == 1 and table["stiff"]["named"] == 2  # planted cause among the named: both
    tensions = {"none": [3.0, 40.0], "stiff": [4e4, 4e4]}
    fig = plot_controls(tensions, table, q_threshold=26.1, label=lambda key: verdict_text(key, sep="\n"))
    a, b = fig.axes[:2]
    assert [ln.get_xdata()[0] for ln in a.lines if ln.get_linestyle() == "--"] == [26.1]
    assert sorted(float(ln.get_xdata()[0]) for ln in a.lines if ln.get_marker() == "o") == [3.0, 4e4]
    cells = sorted(t.get_text() for t in b.texts)
    assert cells == ["1", "1", "1", "1"]  # four verdict cells of one seed each
    assert [t.get_text() for t in b.get_yticklabels()] == ["1/2 as planted", "2/2 as planted"]
    assert b.get_xticklabels()[0].get_text() == "no difference"
    plt.close(fig)

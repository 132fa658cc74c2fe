"""The controls figure: tension per pair against the threshold, verdict counts per scenario."""

import matplotlib.pyplot as plt

from bayestissue.plotting.controls import plot_controls
from bayestissue.workflows.controls import confusion, verdict_text


def _record(name, planted, q, different, named, kind):
    return {"scenario": name, "planted": planted,
            "verdict": {"tension": {"Q": q}, "different": different, "named": named, "kind": kind}}  # fmt: skip


def test_counts_and_threshold_are_drawn():
    records = [
        _record("none", [], 3.0, False, (), "no difference"),
        _record("none", [], 40.0, True, (3,), "named"),  # a false positive
        _record("stiff", [3], 4e4, True, (3,), "named"),
        _record("stiff", [3], 4e4, True, (2, 3), "indistinguishable"),
    ]
    table = confusion(records)
    assert table["none"]["named"] == 1 and table["stiff"]["named"] == 2  # planted cause among the named: both
    fig = plot_controls(records, table, q_threshold=26.1, label=lambda key: verdict_text(key, sep="\n"))
    a, b = fig.axes[:2]
    assert [ln.get_xdata()[0] for ln in a.lines if ln.get_linestyle() == "--"] == [26.1]
    cells = sorted(t.get_text() for t in b.texts)
    assert cells == ["1", "1", "1", "1"]  # four verdict cells of one seed each
    assert [t.get_text() for t in b.get_yticklabels()] == ["1/2 as planted", "2/2 as planted"]
    assert b.get_xticklabels()[0].get_text() == "no difference"
    plt.close(fig)

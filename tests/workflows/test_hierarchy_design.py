"""The specimens file as parsed, and the plain statements of what a design cannot answer (workflows.hierarchy)."""

from pathlib import Path

from bayestissue.workflows.hierarchy import HierarchySpec, SpecimenEntry, design_notes, load_hierarchy

GROUPS = Path(__file__).resolve().parents[2] / "data" / "synthetic" / "tendon_groups" / "specimens.toml"


def _spec(groups):
    entries = tuple(SpecimenEntry(f"s{k}", g, ()) for k, g in enumerate(groups))
    return HierarchySpec(Path("x.toml"), entries, ("k",))


def test_bundled_specimens_file():
    spec = load_hierarchy(GROUPS)
    assert spec.groups == ("fresh", "incubated")
    assert [s.name for s in spec.specimens][:2] == ["fresh_1", "fresh_2"]
    assert spec.parameters == ("k1_1", "beta1") and spec.fit_config.name == "fit.toml"
    assert design_notes(spec) == []  # 4 + 4 specimens: 6 degrees of freedom for the population sd


def test_design_statements():
    one = design_notes(_spec(["a", "a", "a", "b"]))
    assert one[0].startswith("group 'b' has one specimen: its effect is confounded")
    assert one[1].startswith("2 degrees of freedom")  # 3 - 1 in group a, 0 in b
    singletons = design_notes(_spec(["a", "b"]))
    assert any("not identified by these data" in n for n in singletons)
    two = design_notes(_spec(["a", "a"]))
    assert two == ["1 degree of freedom for the population sd (specimens minus groups): its interval is wide and its "
                   "prior matters"]  # fmt: skip
    assert design_notes(_spec(["a", "a", "b", "b"]))[0].startswith("2 degrees of freedom for the population sd")
    assert design_notes(_spec(["a", "a", "b", "b", "b"])) == []  # 3 degrees of freedom: no statement

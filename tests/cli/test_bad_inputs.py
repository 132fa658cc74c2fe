"""Bad input, class by class (issue 19): every case gets one line on stderr naming the file, the field (or line and
column), the value and what was expected, exit status 2 and no traceback, before any expensive work."""

import re
import shutil
from pathlib import Path

import pytest

from bayestissue.cli import main

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture
def t1(tmp_path):
    shutil.copy(DATA / "T1.toml", tmp_path / "T1.toml")
    shutil.copy(DATA / "T1.csv", tmp_path / "T1.csv")
    return tmp_path


def _refused(capsys, argv, pattern):
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert re.search(pattern, err), err


def _edit(path, old, new):
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


EXPERIMENT_CASES = [
    # typos in keys and tables: refused with the nearest valid name, not ignored
    ("stress_kpa", "stres_kpa", r"T1.toml \[protocol\] key: .*got 'stres_kpa' \(did you mean 'stress_kpa'\?\)"),
    ("length_y_mm", "length_w_mm", r"T1.toml \[specimen\] key: .*got 'length_w_mm'"),
    ("[data]", "[tissue]\nfibre_directions = [[1, 0, 0]]\n\n[data]", r"'fibre_directions' \(did you mean 'directions'"),
    ("[data]", "[tisue]\nbulk_kpa = 1\n\n[data]", r"T1.toml table: .*got '\[tisue\]' \(did you mean '\[tissue\]'"),
    # a key of another protocol kind
    (
        'kind = "creep"',
        'kind = "ramp"',
        r"\[protocol\] key: expected one of \['kind', 'mode', 'ratio', 'hold_stress_kpa'.*got 'stress_kpa'",
    ),
    # types: a boolean is not the number 1, a string not a number
    ("length_x_mm = 5.33", "length_x_mm = true", r"T1.toml \[specimen\] length_x_mm: expected a number > 0, got True"),
    ("dt_s = 6.0", 'dt_s = "6"', r"T1.toml \[simulation\] dt_s: expected a number > 0, got '6'"),
    # numerically absurd simulation steps for 1200 s of data
    ("dt_s = 6.0", "dt_s = 1e-9", r"T1.toml simulation.dt_s: expected a step in \[0.0012, 600\] s .*got 1e-09"),
    ("dt_s = 6.0", "dt_s = 1e9", r"T1.toml simulation.dt_s: expected a step in .*got 1000000000.0"),
]


@pytest.mark.parametrize(("old", "new", "pattern"), EXPERIMENT_CASES)
def test_experiment_file(t1, capsys, old, new, pattern):
    _edit(t1 / "T1.toml", old, new)
    _refused(capsys, ["simulate", str(t1 / "T1.toml")], pattern)


def _rows(path):
    lines = path.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("time_s"))
    return lines, header


@pytest.mark.parametrize(
    ("change", "pattern"),
    [
        ("text", r"T1.csv line \d+ column displacement_mm: expected a finite number \(decimal point\), got 'n/a'"),
        ("comma", r"T1.csv line \d+: expected 3 comma-separated values, got .*\(a decimal comma\? use a point\)"),
        ("duplicate", r"T1.csv line \d+ \(header\): expected distinct column names.*\['time_s'\] repeated"),
        ("latin-1", r"T1.csv: expected UTF-8 text \(save the file as UTF-8 CSV\), got 'byte 0xfc at position \d+'"),
        ("nan", r"T1.csv line \d+ column force_mN: expected a finite number"),
    ],
)
def test_data_file(t1, capsys, change, pattern):
    path = t1 / "T1.csv"
    lines, h = _rows(path)
    if change == "text":
        lines[h + 3] = "9,n/a,100.46"
    elif change == "comma":
        lines[h + 3] = "9,0,5,100.46"
    elif change == "duplicate":
        lines[h] = "time_s,time_s,force_mN"
    elif change == "nan":
        lines[h + 3] = lines[h + 3].rsplit(",", 1)[0] + ",nan"
    text = "\n".join(lines) + "\n"
    if change == "latin-1":
        path.write_bytes(("# operator: Jürgen\n" + text).encode("latin-1"))
    else:
        path.write_text(text)
    _refused(capsys, ["simulate", str(t1 / "T1.toml")], pattern)


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16"])
def test_data_file_with_a_byte_order_mark_is_read(t1, capsys, encoding):
    """Spreadsheet programs write a byte-order mark (UTF-8) or UTF-16: the same numbers come out."""
    main(["simulate", str(t1 / "T1.toml"), "--out", str(t1 / "a.csv")])
    (t1 / "T1.csv").write_bytes((t1 / "T1.csv").read_text().encode(encoding))
    assert main(["simulate", str(t1 / "T1.toml"), "--out", str(t1 / "b.csv")]) == 0
    assert (t1 / "a.csv").read_text().splitlines()[2:] == (t1 / "b.csv").read_text().splitlines()[2:]


def test_repeated_parameter(capsys):
    _refused(
        capsys,
        ["simulate", str(DATA / "T1.toml"), "--params", "mu=1,mu=2"],
        r"--params: expected each parameter once, got 'mu=1,mu=2' \(mu given twice\)",
    )


def _counts(tmp_path, rows):
    p = tmp_path / "counts.csv"
    p.write_text("section,smc_points,ecm_points,other_points\n" + "\n".join(rows) + "\n")
    return str(p)


@pytest.mark.parametrize(
    ("first_row", "pattern"),
    [
        ("1,1e300,1,1", r"counts.csv data row 1 column smc_points: expected a whole number of points in \[0, 1e\+07\]"),
        ("1,2.5,1,1", r"counts.csv data row 1 column smc_points: expected a whole number"),
        ("12.9,3,1,1", r"counts.csv data row 1 column section: expected a section number >= 0, got 12.9"),
        ("-6,3,1,1", r"counts.csv data row 1 column section: expected a section number >= 0, got -6.0"),
        ("2,3,1,1", r"counts.csv data row 2 column section: expected each section once, got 2.0"),
    ],
)
def test_point_counts(tmp_path, capsys, first_row, pattern):
    path = _counts(tmp_path, [first_row, "2,3,1,1", "3,3,2,1", "4,2,2,1"])
    _refused(capsys, ["stereology", "fractions", path], pattern)


def test_point_counts_without_a_reference_point(tmp_path, capsys):
    path = _counts(tmp_path, ["1,0,0,3", "2,0,0,1", "3,0,0,1"])
    _refused(capsys, ["stereology", "fractions", path], r"counts.csv column smc_points: expected a point hit, got "
             r"'0 points in every section' \(leave out the column")  # fmt: skip


def test_point_counts_with_one_empty_component(tmp_path, capsys):
    """One component never hit: NaN tables and RuntimeWarnings with exit 0 before (issue 34)."""
    path = _counts(tmp_path, ["1,3,0,1", "2,3,0,1", "3,2,0,1", "4,2,0,1"])
    _refused(capsys, ["stereology", "fractions", path], r"counts.csv column ecm_points: expected a point hit")


def test_replicates_need_two_bootstrap_draws(tmp_path, capsys):
    out = tmp_path / "R.csv"
    _refused(capsys, ["stereology", "replicates", str(DATA / "stereology_counts.csv"),
                      str(DATA / "stereology_lines.csv"), "--n-boot", "1", "--out", str(out)],
             r"--n-boot: expected at least 2 bootstrap replicates")  # fmt: skip
    assert not out.exists()


@pytest.mark.parametrize("n_rows", [1, 3, 14])
@pytest.mark.parametrize("command", ["lines", "replicates"])
def test_line_files_too_short_for_the_mixture(tmp_path, capsys, n_rows, command):
    """A line file of a few segments: the message named n_components, a key the user never set, after the bootstrap
    had started (issue 34); now the file and its rows, before any work."""
    rows = [r for r in (DATA / "stereology_lines.csv").read_text().splitlines() if not r.startswith("#")]
    path = tmp_path / "few.csv"
    path.write_text("\n".join(rows[: n_rows + 1]) + "\n")
    shutil.copy(DATA / "stereology_lines.toml", tmp_path / "few.toml")
    out = tmp_path / "R.csv"
    argv = ["stereology", "lines", str(path)] if command == "lines" else [
        "stereology", "replicates", str(DATA / "stereology_counts.csv"), str(path), "--out", str(out)]  # fmt: skip
    _refused(capsys, argv, rf"few.csv rows: expected at least 15 traced segments .*got '{n_rows} segment")
    assert not out.exists()


def test_rose_top_names_its_option(capsys):
    _refused(capsys, ["stereology", "rose", str(DATA / "stereology_lines.csv"), "--top", "0"], r"k \(--top\)")


def test_image_that_is_not_one(tmp_path, capsys):
    (tmp_path / "stack").mkdir()
    (tmp_path / "stack" / "s01.png").write_text("not an image\n")
    _refused(
        capsys,
        ["micrographs", "analyse", str(tmp_path / "stack"), "--pixel-size-um", "1", "--section-thickness-um", "5",
         "--out", str(tmp_path / "o")],
        r"image .*s01.png: expected a readable PNG image",
    )  # fmt: skip


def _output_cases(tmp_path):
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    counts, lines = str(DATA / "stereology_counts.csv"), str(DATA / "stereology_lines.csv")
    t1 = str(DATA / "T1.toml")
    return [
        (["simulate", t1, "--out", "adir"], r"--out: expected a file name \(this is a folder\)"),
        (["simulate", t1, "--out", "afile/x.csv"], r"--out: expected a path under a folder.*afile is a file"),
        (["fit", t1, "--out", "afile"], r"--out: expected a folder \(an existing file is in the way\)"),
        (["fit", t1, "--out", "afile/run"], r"--out: expected a path under a folder"),
        (["stereology", "rose", lines, "--out", "adir"], r"--out: expected a file name"),
        (["stereology", "replicates", counts, lines, "--out", "afile/r.csv"], r"--out: expected a path under a folder"),
        (["micrographs", "phantom", "afile"], r"OUTDIR: expected a folder"),
        (["micrographs", "analyse", "adir", "--pixel-size-um", "1", "--section-thickness-um", "5", "--out", "afile"],
         r"--out: expected a folder"),
    ]  # fmt: skip


def test_output_paths(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for argv, pattern in _output_cases(tmp_path):
        _refused(capsys, argv, pattern)


def test_a_table_given_a_plain_value(t1, capsys):
    (t1 / "T1.toml").write_text("tissue = 5\n" + (t1 / "T1.toml").read_text())
    _refused(capsys, ["simulate", str(t1 / "T1.toml")], r"T1.toml \[tissue\]: expected a \[tissue\] table .*got 5")


def test_ctrl_c_prints_one_line_and_how_to_resume(tmp_path, capsys, monkeypatch):
    """A KeyboardInterrupt during a command: no traceback, exit 130, and for fit where to resume from."""
    import bayestissue.cli.fit as fit

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(fit, "run", interrupted)
    code = main(["fit", str(DATA / "T1.toml"), "--out", str(tmp_path / "run")])
    err = capsys.readouterr().err
    assert code == 130 and err.count("\n") == 1 and "Traceback" not in err
    assert "interrupted; what was checkpointed in" in err and "--resume continues it" in err


def test_messages_that_name_what_to_act_on(t1, tmp_path, capsys):
    """Issue 34's probe: a binary TOML, a folder for a file, an empty data file name, a negative seed."""
    (tmp_path / "bin.toml").write_bytes(bytes(range(128, 256)))
    _refused(
        capsys,
        ["simulate", str(tmp_path / "bin.toml")],
        r"experiment bin.toml: expected UTF-8 text \(a TOML file; is this a binary file\?\), got 'byte 0x80",
    )
    _refused(capsys, ["simulate", str(tmp_path)], r"experiment file: expected a TOML file \(this is a folder\)")
    _edit(t1 / "T1.toml", 'file = "T1.csv"', 'file = ""')
    _refused(capsys, ["simulate", str(t1 / "T1.toml")], r"table file: expected a CSV file \(this is a folder\)")
    with pytest.raises(SystemExit) as exit_:  # argparse's own refusal: usage line, then the one-line error
        main(["fit", str(DATA / "T1.toml"), "--out", str(tmp_path / "r"), "--seed", "-1"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "argument --seed: expected an integer >= 0, got '-1'" in err and "Traceback" not in err


@pytest.mark.parametrize(
    "rows, pattern",
    [
        (
            "[[1, 0], [0, 1, 0], [0, 0, 1]]",
            r"\[tissue\] directions row 1: expected three numbers \[x, y, z\], got \[1, 0\]",
        ),
        (
            "[[1, 0, 0], [nan, 1, 0], [0, 0, 1]]",
            r"\[tissue\] directions row 2: expected finite numbers, got \[nan, 1, 0\]",
        ),
    ],
)
def test_direction_rows_are_named_by_number(t1, capsys, rows, pattern):
    """A short row gave numpy's 'inhomogeneous shape'; a NaN 'a list of [x, y, z] rows' (issue 34)."""
    _edit(t1 / "T1.toml", "[data]", f"[tissue]\ndirections = {rows}\n\n[data]")
    _refused(capsys, ["simulate", str(t1 / "T1.toml")], pattern)


def test_fit_refuses_a_cut_it_cannot_run(t1, tmp_path, capsys):
    """fit --replicates: a dispersed fibre law with a table without dispersions, one replicate, no sampling."""
    from bayestissue.io.stereology_files import write_replicates
    from bayestissue.stereology import LineSystem, PointCounts, stereology_replicates

    cols, _ = stereology_replicates(PointCounts.from_file(DATA / "stereology_counts.csv"),
                                    LineSystem.from_file(DATA / "stereology_lines.csv"), n_boot=3, rng=3)  # fmt: skip
    path = tmp_path / "R.csv"
    write_replicates(path, cols)
    hgo_t1 = t1 / "T1.toml"
    _edit(hgo_t1, "[data]", '[tissue]\nfibre = "hgo"\n\n[data]')
    plain = {k: v for k, v in cols.items() if not k.startswith("disp_")}
    write_replicates(tmp_path / "plain.csv", plain)
    out = str(tmp_path / "out")
    plain_argv = ["fit", str(hgo_t1), "--replicates", str(tmp_path / "plain.csv"), "--out", out]
    _refused(capsys, plain_argv, r"T1.toml: replicate table: expected the families' dispersions for \['disp1', 'disp2'")
    _refused(capsys, ["fit", str(hgo_t1), "--replicates", str(path), "--n-replicates", "1", "--out", out],
             r"--n-replicates: expected an integer >= 2")  # fmt: skip
    _refused(capsys, ["fit", str(hgo_t1), "--replicates", str(path), "--no-sample", "--out", out],
             r"--replicates: expected a sampled run")  # fmt: skip
    assert not Path(out).exists()


@pytest.fixture
def groups_study(tmp_path):
    """A copy of the bundled specimens file of `bayestissue hierarchy` (data/synthetic/tendon_groups)."""
    shutil.copytree(DATA / "synthetic" / "tendon_groups", tmp_path, dirs_exist_ok=True)
    return tmp_path


@pytest.mark.parametrize(
    "old, new, pattern",
    [
        ('reference_group = "fresh"', 'reference_grup = "fresh"',
         r"specimens.toml: key: .*got 'reference_grup' \(did you mean 'reference_group'\?\)"),
        ('parameters = ["k1_1", "beta1"]', 'parameters = ["k1", "beta1"]',
         r"specimens.toml: parameters: .*got 'k1' \(did you mean 'k1_1'\?"),
        ('parameters = ["k1_1", "beta1"]', 'parameters = ["k1_1", "k2_1"]',
         r"specimens.toml: parameters: expected a sampled parameter.*got 'k2_1'"),
        ('experiments = ["fresh_2.toml"]', 'experiments = ["fresh_9.toml"]',
         r"specimen fresh_2 experiments: expected an existing experiment file, got '.*fresh_9.toml'"),
        ('name = "fresh_2"', 'name = "fresh_1"', r"specimen 2 name: expected a name no other specimen has"),
        ('reference_group = "fresh"', 'reference_group = "old"', r"reference_group: expected one of the specimens"),
        ("seed = 1", "seed = 1\nchains = 1", r"\[population\] chains: expected an integer >= 2, got 1"),
        ("seed = 1", "sd_scale = { k1_1 = -1 }", r"\[population\] sd_scale.k1_1: expected a positive number"),
        ("seed = 1", "strain = 5", r"\[population\] strain: expected a nominal strain in \(0, 2\), got 5"),
    ],
)  # fmt: skip
def test_bad_specimens_file(groups_study, capsys, old, new, pattern):
    path = groups_study / "specimens.toml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))
    _refused(capsys, ["hierarchy", str(path), "--out", str(groups_study / "run"), "--quick"], pattern)
    assert not (groups_study / "run").exists()


def test_specimens_of_different_models_refused(groups_study, capsys):
    """A specimen whose experiment has two branches samples other parameters: refused before any fit."""
    exp = groups_study / "incubated_1.toml"
    exp.write_text(exp.read_text().replace("fibre_branches = 1", "fibre_branches = 2"))
    _refused(capsys, ["hierarchy", str(groups_study / "specimens.toml"), "--out", str(groups_study / "run"), "--quick"],
             r"specimen incubated_1 model: expected the sampled parameters of specimen fresh_1")  # fmt: skip
    assert not (groups_study / "run" / "specimens").exists()


CLUSTER_OPTIONS = [
    (["--workers", "0"], r"--workers: expected an integer >= 1, got 0"),
    (["--scheduler", "host:8786"], r"--scheduler: expected a scheduler address"),
]


@pytest.mark.parametrize("args, pattern", CLUSTER_OPTIONS)
def test_bad_cluster_options_refused(groups_study, capsys, args, pattern):
    _refused(capsys, ["hierarchy", str(groups_study / "specimens.toml"), "--out", str(groups_study / "run"), *args],
             pattern)  # fmt: skip
    assert not (groups_study / "run").exists()

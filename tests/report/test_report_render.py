"""REPORT.md rendered from fixture records: the stored expected output, the answers first, verdicts from the records.

The fixtures (tests/report/fixtures/*.json) are the records of a default study run; REPORT.md beside them is the
expected rendering. After an intended change of the template, regenerate it with
``python studies/report.py --out tests/report/fixtures`` and read the diff.
"""

import dataclasses
import shutil
from pathlib import Path

import numpy as np
import pytest

from bayestissue.analyses import model_choice as MC
from bayestissue.analyses.records import FILES, ControlsRecord, DiscrepancyRecord, MeasuredRecord, RateTruth
from bayestissue.io.records import RecordError, read_record, write_record
from bayestissue.report import read_study_records, render_report

FIXTURES = Path(__file__).parent / "fixtures"


@pytest.fixture(scope="module")
def records():
    return read_study_records(FIXTURES)


def test_fixture_records_render_to_the_stored_report(records):
    expected = (FIXTURES / "REPORT.md").read_text()
    assert render_report(records) == expected


def test_the_report_opens_with_the_answers(records):
    lines = render_report(records).splitlines()
    start = lines.index("## Answers")
    assert start < 8
    answers = lines[start : start + 12]
    joined = "\n".join(answers)
    for question in ("Do the posteriors hold?", "What does each test identify?", "Is the T1/T2 difference real?",
                     "Which cause?"):  # fmt: skip
        assert question in joined
    assert "**yes** | tension Q = 40897 on 11 df" in joined
    assert "**partial**: fibre angle + specimen stiffness" in joined
    # the report before the template: 7 500 words; 4 517 after it, 5 452 with the laws section (issue 32), about
    # 6 100 with the specimens section (issue 35; its tables of typical and new specimens stay in their summary),
    # 6 260 -> 6 450 with the rate study's further truths (a table of 8 rows), 7 235 with the model choice (issue 36:
    # per test a table of the 11 parameters beside Table 1, 2 rows of runs' evidence and a line of verdict), 7 997
    # with the joint data set (3 rows of runs, the stiffness scale's factor) and the fixture's box-width table (4 rows),
    # 8 677 with the branch count (issue 32: an answers row of 46 words, a section of 436 with tables of 3 and 6 rows),
    # 9 270 with the evidence by importance sampling (issue 36: a table of 7 rows, a bullet per factor, both estimators
    # in the answers rows), 9 666 with the checks' box-width table (4 rows and its paragraph) and the line on the
    # collapsed check (the fixture now holds one), 10 014 with the joint data set's parameters by importance sampling
    # (a table of 13 rows)
    assert sum(len(line.split()) for line in lines) < 10200


def test_verdicts_follow_the_records(records):
    """Change a measurement in a record: the verdict the report states changes with it."""
    D = records.discrepancy
    cp = dict(D.cross_prediction)
    cp["T2|T1"] = dataclasses.replace(cp["T2|T1"], coverage=0.9)  # the T1 posterior predicts T2 after all
    text = render_report(dataclasses.replace(records, discrepancy=dataclasses.replace(D, cross_prediction=cp)))
    assert "| Is the T1/T2 difference real? | **not established** |" in text
    assert "**Not established** ([rule]" in text
    K = records.controls
    chi2 = dict(K.data.chi2, **{"2": K.data.chi2["T1"] + K.data.chi2["T2"] + 3.0})  # the angle alone explains it
    data = dataclasses.replace(K.data, chi2=chi2)
    text = render_report(dataclasses.replace(records, controls=dataclasses.replace(K, data=data)))
    assert "| Which cause? (controlled rules) | **named**: fibre angle |" in text
    assert "this verdict is a false attribution" in text


def test_stages_that_did_not_run_leave_their_sections_out(tmp_path):
    for cls in (DiscrepancyRecord,):
        shutil.copy(FIXTURES / FILES[cls], tmp_path)
    with pytest.raises(RecordError, match="identifiability_record.json: expected a bayestissue.identifiability"):
        read_study_records(tmp_path)
    shutil.copy(FIXTURES / "identifiability_record.json", tmp_path)
    text = render_report(read_study_records(tmp_path))
    assert "The controls stage did not run: no cause verdict." in text
    assert "Which cause?" not in text.split("## 1.")[0]  # no answer without the controls
    assert "## 6." not in text and "Recovery of the generating values" not in text


def test_a_record_of_another_version_is_refused_by_name(tmp_path):
    rec = read_record(FIXTURES / FILES[MeasuredRecord], MeasuredRecord)
    path = write_record(tmp_path / FILES[MeasuredRecord], rec)
    path.write_text(path.read_text().replace('"version": 1', '"version": 0'))
    with pytest.raises(RecordError, match="measured_record.json version: expected version 1"):
        read_record(path, MeasuredRecord)
    assert read_record(FIXTURES / FILES[ControlsRecord], ControlsRecord).n_shared == 8


def test_tissue_terms_follow_the_records(records):
    """The tissue-terms table states whether T1's and T2's intervals overlap from the record's numbers."""
    text = render_report(records)
    assert "| secant modulus (instantaneous) | kPa | 57 [53.8, 61.6] | 54 [53.5, 64.6] |" in text
    assert (
        "| secant modulus (equilibrium) | kPa | 8.83 [7.15, 14.2] | 52.7 [49.9, 53.6] | 17.8 [17.2, 18.1] | **apart** |"
        in text
    )
    T = records.tissue_terms
    runs = {**T.runs, "T2_mirror": {**T.runs["T2_mirror"], "secant modulus (equilibrium)": [12.0, 10.0, 50.0]}}
    moved = render_report(dataclasses.replace(records, tissue_terms=dataclasses.replace(T, runs=runs)))
    assert (
        "| secant modulus (equilibrium) | kPa | 8.83 [7.15, 14.2] | 12 [10, 50] | 17.8 [17.2, 18.1] | overlap |"
        in moved
    )
    no_terms = render_report(dataclasses.replace(records, tissue_terms=None))
    assert "in a tissue's terms" not in no_terms


def test_specimens_section_follows_the_record(records):
    """Section 8 and its answer state a group difference from the record's interval, and leave both out without the
    record."""
    H = records.hierarchy
    text = render_report(records)
    assert "## 8. Specimens and groups" in text
    assert (
        "Do two groups of specimens differ, beyond specimen variability? (synthetic tendon study) | k1_1: **yes**"
        in text
    )
    case = H.cases[0]
    effects = {**case.effects, "incubated:k1_1": [0.9, 0.7, 1.2, 0.3]}  # an interval that contains 1
    moved = dataclasses.replace(H, cases=[dataclasses.replace(case, effects=effects), *H.cases[1:]])
    text = render_report(dataclasses.replace(records, hierarchy=moved))
    assert "k1_1: not shown" in text
    assert "no difference shown (the interval contains 1)" in text
    none = render_report(dataclasses.replace(records, hierarchy=None))
    assert "## 8." not in none and "Do two groups" not in none


def test_specimens_tissue_terms_follow_the_record(records):
    """The table of the groups in a tissue's terms shows the record's values, and is left out for a case without
    them."""
    case = records.hierarchy.cases[0]
    text = render_report(records)
    assert "In a tissue's terms at nominal strain 0.05" in text
    tissue = {**case.tissue_effects, "incubated:secant modulus (instantaneous)": [0.25, 0.2, 0.3, 0.0]}
    moved = dataclasses.replace(records.hierarchy, cases=[dataclasses.replace(case, tissue_effects=tissue),
                                                          *records.hierarchy.cases[1:]])  # fmt: skip
    text = render_report(dataclasses.replace(records, hierarchy=moved))
    assert "| secant modulus (instantaneous) | kPa |" in text and "| ratio 0.25 [0.2, 0.3] |" in text
    empty = dataclasses.replace(case, tissue_units={}, tissue={}, tissue_effects={}, tissue_strain=0.0)
    bare = dataclasses.replace(records.hierarchy, cases=[empty, *records.hierarchy.cases[1:]])
    assert "In a tissue's terms" not in render_report(dataclasses.replace(records, hierarchy=bare))


def test_the_rate_answer_counts_the_truths_drawn_from_t1(records):
    """The answer at T2's rate is a count over truths drawn from T1's posterior (the best draw and the rest): all or
    none is an answer, a count in between is called borderline, in the answers table and in section 3."""
    D, R = records.discrepancy, records.discrepancy.rates
    visc = ("gamma2", "beta2")

    def truth(beta2, closed):
        ci = {"gamma2": (0.85, 0.95), "beta2": (beta2 / 2, beta2 * 2)} if closed else {p: (None, None) for p in visc}
        cls = "identifiable" if closed else "practically non-identifiable"
        return RateTruth(truth={"gamma2": 0.9, "beta2": beta2}, classification=dict.fromkeys(visc, cls), ci=ci)

    def answer(best_closed, draws):
        best = truth(3e-4, best_closed)
        profiles = dict(R.profiles, **{"1": dataclasses.replace(R.profiles["1"], ci=best.ci)})
        rates = dataclasses.replace(R, profiles=profiles, at_t2=draws)
        text = render_report(dataclasses.replace(records, discrepancy=dataclasses.replace(D, rates=rates)))
        row = next(line for line in text.splitlines() if line.startswith("| What can a test at T2's rate see"))
        return row, text

    row, text = answer(True, [truth(b, True) for b in (1e-4, 2e-4, 5e-4)])
    drawn = "of 4 truths drawn from T1's posterior"
    assert f"its strength (gamma2) in all 4, its time scale (beta2) in all 4, {drawn}" in row
    assert "borderline" not in row
    row, text = answer(True, [truth(1e-4, True), truth(2e-3, False), truth(5e-3, False)])
    assert f"its strength (gamma2) in **2**, its time scale (beta2) in **2**, {drawn} (borderline" in row
    assert "| 0.9 | 0.002 | [open, open] | [open, open] |" in text  # section 3 lists every draw
    row, _ = answer(False, [truth(2e-3, False)])
    assert "its strength (gamma2) in none, its time scale (beta2) in none, of 2 truths" in row


def test_the_box_width_table_gives_how_ln_b_moves_and_which_bounds_hold_mass(records):
    """Without boxes no table; with them, the differences of the two models' shifts, and the bounds holding at least
    EDGE_SHARE of a posterior."""
    from bayestissue.analyses.box_width import BoxShift
    from bayestissue.report.model_choice import EDGE_SHARE

    rec = records.model_choice
    none = {d: dataclasses.replace(c, models={k: dataclasses.replace(e, box=None) for k, e in c.models.items()})
            for d, c in rec.cases.items()}  # fmt: skip
    assert "How ln B moves" not in render_report(
        dataclasses.replace(records, model_choice=dataclasses.replace(rec, cases=none))
    )
    case = rec.cases["T1"]

    def box(narrowed, volume, flat, edge):
        return BoxShift(
            factor=10.0,
            names=["mu", "ginf1"],
            narrowed_runs=[narrowed] * 4,
            narrowed_errs=[0.1] * 4,
            narrowed=(narrowed, 0.3),
            widened_volume=volume,
            edge_share=edge,
            widened_flat=flat,
        )

    boxes = {
        "mirror": box(-1.0, -0.5, -0.2, [(0.3, 0.0), (0.01, 0.0)]),
        "full": box(-2.5, -0.9, -0.4, [(EDGE_SHARE, 0.0), (0.0, 0.2)]),
    }
    models = {k: dataclasses.replace(e, box=boxes[k]) for k, e in case.models.items()}
    changed = dataclasses.replace(rec, cases={"T1": dataclasses.replace(case, models=models)})
    text = render_report(dataclasses.replace(records, model_choice=changed))
    row = next(line for line in text.splitlines() if line.startswith("| T1 | ") and "+1.50 +- 0.42" in line)
    assert "| +1.50 +- 0.42 | " + ", ".join(["-1.00"] * 4) + "; " + ", ".join(["-2.50"] * 4) in row
    assert "| +0.40 | +0.20 | mu low 0.30; mu low 0.05, ginf1 high 0.20 |" in row


def test_the_model_choice_follows_the_runs_agreement_on_the_evidence_and_the_code(records):
    """The evidence chooses the study's model only from runs that agree on each evidence and a positive factor
    (whatever the posterior verdict); the report says when the committed record belongs to other code (the fixture's
    hashes are deliberately not a code's)."""
    rec = records.model_choice
    assert {e.numbers_hash for c in rec.cases.values() for e in c.models.values()} == {"fixture-not-code"}

    def render(agree, shift=0.0, now=None):
        case = rec.cases["T1"]
        m, f = case.models["mirror"], case.models["full"]

        def runs(e, z):
            return dataclasses.replace(
                e,
                converged=False,
                merged=(z, 0.1),
                log_z=[z] * 4,
                log_z_err=[0.2] * 4,
                finished=[True] * 4,
                peak_reached=[True] * 4,
                log_z_p=0.5 if agree else 0.001,
            )

        models = {"mirror": runs(m, f.merged[0] + shift), "full": runs(f, f.merged[0])}
        changed = dataclasses.replace(rec, cases={"T1": dataclasses.replace(case, models=models)})
        now = {"T1": {"mirror": now or "0" * 16, "full": "fixture-not-code"}}
        text = render_report(
            dataclasses.replace(records, model_choice=changed, model_choice_now=now, evidence_check=None)
        )
        row = next(line for line in text.splitlines() if line.startswith("| Which model do the data support"))
        return row, text

    row, text = render(True, shift=2.0)  # ln B = 2 +- 0.14: positive for the mirror model
    assert "| T1: **mirror** (nested runs) (the analyses use the mirror model) | T1: ln B mirror over full" in row
    assert "by the nested runs 2.00 +- 0.14 (positive;" in row
    assert "**stale**: the mirror model's runs belong to other code" in text
    assert "(rerun `python studies/full_model.py --full --data T1 --models mirror`, which reruns only those)" in text
    row, _ = render(True, shift=-4.0)
    assert "| T1: **full** (nested runs) | T1: ln B mirror over full by the nested runs -4.00 +- 0.14 (strong;" in row
    assert "| agree (scatter p = 0.5) | NOT CONVERGED |" in text
    row, text = render(False, shift=2.0, now="fixture-not-code")
    assert "| T1: not decided (the analyses use the mirror model) |" in row
    assert "runs agree on the evidence: mirror **no**, full **no**" in row
    assert "the current code's" in text and "the runs of the mirror and full model disagree on its evidence" in text
    assert "| **DISAGREE** (scatter p = 0.001) |" in text
    row, _ = render(True, shift=0.2)
    assert "T1: not decided" in row and "(within error;" in row


def test_the_joint_data_set_reports_a_t2_stiffness_scale_beside_the_model_choice(records):
    """On the joint data set the report adds ln B of a T2 stiffness scale over shared parameters (with the scale's
    interval when the evidence decides for it) and has no Table 1 block (the paper gives values per test)."""
    rec = records.model_choice
    t1 = rec.cases["T1"]

    def runs(e, z, model=None, extra=None):
        e = dataclasses.replace(e, merged=(z, 0.1), log_z=[z] * 4, log_z_err=[0.2] * 4, finished=[True] * 4,
                                peak_reached=[True] * 4, max_log_l=[1.0] * 4, log_z_p=0.5)  # fmt: skip
        if extra is None:
            return e
        u = [0.5, 0.55, 0.6]
        return dataclasses.replace(e, model=model, names=[*e.names, "scale"], quantiles=[*e.quantiles, extra],
                                   quantile_errors=[*e.quantile_errors, [0.01] * 3],
                                   unit_quantiles=[*e.unit_quantiles, u],
                                   run_unit_quantiles=[[*r, u] for r in e.run_unit_quantiles], box=None)  # fmt: skip

    def render(shift):
        m, f = t1.models["mirror"], t1.models["full"]
        z = f.merged[0]
        models = {"mirror": runs(m, z + 3.0), "full": runs(f, z), "scale": runs(m, z + 3.0 + shift, "scale",
                                                                                 [0.8, 1.3, 2.0])}  # fmt: skip
        joint = MC.DataChoice(data="joint", seed=MC.STAGE_SEED + 20, models=models)
        changed = dataclasses.replace(rec, cases={**rec.cases, "joint": joint})
        return render_report(dataclasses.replace(records, model_choice=changed, evidence_check=None))

    text = render(4.0)
    assert (
        "ln B scale over mirror (a stiffness scale of T2's specimen against shared parameters) **4.00 +- 0.14**" in text
    )
    assert (
        "strong for a stiffness scale: the evidence says T2's specimen differs in stiffness (scale 1.3 [0.8, 2" in text
    )
    assert "| joint | scale | ultranest |" in text and "| joint | paper |" not in text and "| T1 | paper |" in text
    answer = (
        "(evidence on both tests jointly) | **yes** (nested runs): T2's moduli 1.3 [0.8, 2] x T1's | ln B scale over"
    )
    assert (
        f"| Do the two specimens differ in stiffness alone? {answer} mirror by the nested runs 4.00 +- 0.14 (strong;"
        in text
    )
    text = render(-4.0)
    assert "differ in stiffness alone? (evidence on both tests jointly) | **no** (nested runs) |" in text
    assert "strong for shared parameters: the evidence says one parameter set serves both tests" in text
    assert "not decided" not in text.split("- **joint**")[1].split("\n")[0]


def test_a_data_set_whose_models_have_not_all_run_says_which_factor_waits_for_which_model(records):
    """A data set's models may run in separate sessions (``full_model.py --models``): with only the joint mirror
    model run, its runs are listed, no factor is computed or decided, and the report names the models still to run."""
    rec = records.model_choice
    joint = rec.cases["joint"]
    partial = dataclasses.replace(joint, models={"mirror": joint.models["mirror"]})
    changed = dataclasses.replace(rec, cases={**rec.cases, "joint": partial})
    text = render_report(dataclasses.replace(records, model_choice=changed, evidence_check=None))
    assert "| joint | mirror | ultranest |" in text and "| joint | full |" not in text
    bullet = text.split("- **joint**:")[1].split("\n")[0]
    assert "ln B mirror over full not yet: the full model has not run" in bullet
    assert "ln B scale over mirror not yet: the scale model has not run" in bullet
    assert "--data joint --models scale" in bullet and "**" not in bullet.split("Code and data")[0]
    assert "| Which model do the data support" in text and "joint: not yet, a model has not run" in text
    assert "joint: ln B mirror over full the nested runs of the full model not run yet |" in text
    assert "| Do the two specimens differ in stiffness alone? (evidence on both tests jointly) | not run yet |" in text
    # the tests run on their own are still decided as before
    alone = render_report(dataclasses.replace(records, evidence_check=None))
    assert alone.split("- **T1**:")[1].split("\n")[0] == text.split("- **T1**:")[1].split("\n")[0]


def test_the_wall_time_is_projected_from_the_runs_measured_times(records):
    """On W workers a model's R unsplit runs take ceil(R / W) mean run times: the fixture's 2 runs per model give one
    run's time on 4 workers and two on 1."""
    rec = records.model_choice
    line = next(x for x in render_report(records).splitlines() if x.startswith("Wall time:"))
    for data, case in rec.cases.items():
        for model, e in case.models.items():
            t = float(np.mean(e.time_s))
            assert len(e.time_s) == 2
            assert f"{data} {model} {2 * t:.0f} s on 1 worker, {t:.0f} s on 4 workers" in line


def test_a_model_resumed_over_sessions_says_so_instead_of_one_sessions_times(records):
    """A model whose runs were resumed from an earlier session's checkpoint has no measured wall time (NaN): its row
    says "resumed over sessions"; a run whose earlier sessions' seconds were not recorded (NaN) leaves that model
    without a projection, and the other models keep theirs."""
    rec = records.model_choice
    data, case = next(iter(rec.cases.items()))
    model, e = next(iter(case.models.items()))
    resumed = dataclasses.replace(e, wall_s=float("nan"), time_s=[float("nan")] + list(e.time_s[1:]))
    changed = dataclasses.replace(
        rec, cases={**rec.cases, data: dataclasses.replace(case, models={**case.models, model: resumed})}
    )
    text = render_report(dataclasses.replace(records, model_choice=changed))
    row = next(x for x in text.splitlines() if x.startswith(f"| {data} | {model} |"))
    assert row.endswith("| resumed over sessions |") and "nan" not in row
    line = next(x for x in text.splitlines() if x.startswith("Wall time:"))
    assert f"{data} {model} not projected (a run's time was not recorded)" in line
    other, o = next((k, v) for k, v in case.models.items() if k != model)
    assert f"{data} {other} {2 * float(np.mean(o.time_s)):.0f} s on 1 worker" in line
    assert "nan" not in line


def test_the_branch_count_section_states_the_pick_the_rule_and_stale_runs(records):
    """Section 9 and its answers row follow the branch-count record: the pick and the bound on the scattered
    three-branch runs; no pick once the two-branch runs disagree too; current runs lose the stale line; no section
    without the record."""
    text = render_report(records)
    row = next(x for x in text.splitlines() if x.startswith("| How many relaxation times"))
    assert (
        "| **2 branches** |" in row
        and "ln B 2 over 3 1.98 +- 0.09 (positive; 3-branch runs disagree, bound 1.43)" in row
    )
    section = text.split("## 9. Relaxation branches by the evidence")[1]
    assert "**The evidence picks 2 branches** (the generating count)" in section
    assert "even their highest run plus two of their sds lies 1.43 nats below 2 branches" in section
    assert "| 1 | 6 | -731.03 +- 0.01 | yes (p = 0.67) | **MISFIT** | 3.49, 0.90 | yes |" in section
    assert "- **Stale**: the runs of 1, 2, 3 branch(es)" in section  # the fixture's hashes are no code's
    assert "for 9 of its 9 tissue terms (`workflows" in section
    assert "| relaxation time t1_2 | s | 30 | - | 29.78 [29.18, 30.47] | 2.013 [1.051, 29.04] |" in section
    B = records.branch_count
    two = B.fits["2"]
    scattered = dataclasses.replace(B, fits={**B.fits, "2": dataclasses.replace(two, evidence=dataclasses.replace(
        two.evidence, log_z_p=0.001))})  # fmt: skip
    now = {n: B.fits[str(n)].evidence.numbers_hash for n in B.counts}
    text = render_report(dataclasses.replace(records, branch_count=scattered, branch_count_now=now))
    row = next(x for x in text.splitlines() if x.startswith("| How many relaxation times"))
    assert "| not decided |" in row
    assert "**The evidence does not decide** (largest log Z: 2 branches)" in text
    assert "does not decide (the 2-branch runs disagree)" in text and "- **Stale**: the runs of" not in text
    text = render_report(dataclasses.replace(records, branch_count=None))
    assert "How many relaxation times" not in text and "## 9." not in text


def test_a_trusted_importance_sampling_factor_rules_the_model_choice(records):
    """With both importance-sampling evidences trusted, their factor chooses (strong for the full model here, where
    the nested runs say within error for the mirror model), the answers row and the section say so and name the
    estimator; two decisions for different models choose nothing; untrusted checks leave the nested rule."""
    check = records.evidence_check
    t1 = check.cases["T1"]

    def render(shift, trusted=True, nested_shift=None):
        m, f = t1.checks["mirror"], t1.checks["full"]
        checks = {"mirror": dataclasses.replace(m, log_z=f.log_z + shift, log_z_err=0.05, trusted=trusted),
                  "full": dataclasses.replace(f, log_z_err=0.05, trusted=trusted)}  # fmt: skip
        changed = dataclasses.replace(check, cases={"T1": dataclasses.replace(t1, checks=checks)})
        mc = records.model_choice
        if nested_shift is not None:
            case = mc.cases["T1"]
            mm, ff = case.models["mirror"], case.models["full"]
            agree = {"log_z_p": 0.5, "finished": [True] * 4, "peak_reached": [True] * 4}
            models = {"mirror": dataclasses.replace(mm, merged=(ff.merged[0] + nested_shift, 0.1), **agree),
                      "full": dataclasses.replace(ff, merged=(ff.merged[0], 0.1), **agree)}  # fmt: skip
            mc = dataclasses.replace(mc, cases={**mc.cases, "T1": dataclasses.replace(case, models=models)})
        text = render_report(dataclasses.replace(records, evidence_check=changed, model_choice=mc))
        row = next(line for line in text.splitlines() if line.startswith("| Which model do the data support"))
        return row, text

    row, text = render(-4.0)
    assert row.startswith("| Which model do the data support: the paper's 11 parameters or the mirror model? | T1: "
                          "**full** (importance sampling);")  # fmt: skip
    assert "T1: ln B mirror over full by importance sampling -4.00 +- 0.50 (strong), by the nested runs" in row
    assert "- **T1**, ln B mirror over full: by importance sampling **-4.00 +- 0.50** (strong)" in text
    assert "the evidence chooses the **full** model (importance sampling)." in text
    assert "(the analyses use the mirror model)" not in row
    _, text = render(0.05)  # trusted and within error: no choice, whatever the nested runs say
    assert "T1: not decided;" in text
    row, text = render(4.0, nested_shift=-4.0)  # both decide, for different models
    assert "T1: the estimators disagree;" in row
    assert "(**apart**: more than 2 of their combined errors): the estimators disagree." in text
    row, _ = render(4.0, trusted=False, nested_shift=-4.0)  # an untrusted check leaves the nested runs' choice
    assert "T1: **full** (nested runs);" in row and "(strong, **not trusted**)" in row


def test_a_check_with_a_parameter_integrated_out_says_so_with_its_quadratures_counts(records):
    """A check made with kappa integrated out by quadrature (its record's ``quadrature``: the joint full model) gets a
    line naming the parameter and the quadrature's counts and share of the weight, read from the record's fields (not
    its verdict); a check without them gets none; one labelling of the mirror families is said where it was used."""
    from bayestissue.analyses.evidence_check import CheckCase, Quadrature

    check = records.evidence_check
    full = check.cases["T1"].checks["full"]
    counts = (
        "41-point bracket of +-0.0679 (largest regression residual 0.0453), 6 Newton steps, 12 Gauss-Hermite "
        "nodes: peak on the bracket's edge at 3 of 20000 points, not concave at 1"
    )
    quad = Quadrature("kappa", False, counts, 20000, 0, 3, 1, 0.0004)
    line = "joint full: its posterior is a curved sheet far thinner across kappa than along it"
    for made, expected in ((dataclasses.replace(full, quadrature=quad), True), (full, False)):
        cases = {**check.cases, "joint": CheckCase("joint", {"full": made})}
        text = render_report(dataclasses.replace(records, evidence_check=dataclasses.replace(check, cases=cases)))
        assert (line in text) is expected
        assert (counts + ", holding 0.0004 of the weight." in text) is expected
        assert "on one labelling of the mirror families" not in text.split(line)[-1].split("\n")[0]
    labelled = dataclasses.replace(full, quadrature=dataclasses.replace(quad, param="beta3", one_labelling=True))
    cases = {**check.cases, "T1": CheckCase("T1", {"full": labelled})}
    text = render_report(dataclasses.replace(records, evidence_check=dataclasses.replace(check, cases=cases)))
    assert "T1 full: its posterior is a curved sheet far thinner across beta3 than along it" in text
    assert "on one labelling of the mirror families (family 3 the softer by ginf, so beta3 is the softer" in text


def test_the_joint_data_set_gets_its_parameters_by_importance_sampling_beside_both_tables_1(records):
    """The joint data set has no Table 1 block of nested posteriors: its checked models' quantiles under the weights
    stand beside the paper's T1 and T2 values and our joint least squares, a mirror model's tied parameters name their
    source, a parameter of one model alone (the stiffness scale) is blank elsewhere, the ESS of each check is given and
    an untrusted one is marked; without the checks there is no table."""
    check = records.evidence_check
    joint = check.cases["joint"]
    full = joint.checks["full"]
    q = [list(x) for x in full.quantiles]
    q[1] = [15.4, 18.9, 21.4]  # kappa
    checks = {**joint.checks, "full": dataclasses.replace(full, quantiles=q, ess=33.0, trusted=True),
              "mirror": dataclasses.replace(joint.checks["mirror"], ess=257.0, trusted=True)}  # fmt: skip
    changed = dataclasses.replace(check, cases={**check.cases, "joint": dataclasses.replace(joint, checks=checks)})
    text = render_report(dataclasses.replace(records, evidence_check=changed))
    head = "| joint | paper T1 | paper T2 | least squares | mirror model: median [90 %] | full model: median [90 %] |"
    assert head + " scale model: median [90 %] |" in text
    rows = {line.split(" | ")[0]: line for line in text.split(head)[1].split("\n\n")[0].splitlines()[2:]}
    ls = records.identifiability.profile_reference["joint"].theta_final[1]
    kappa = rows["| kappa"].split(" | ")
    assert kappa[1:4] == ["2.91", "68.5", f"{ls:.3g}"] and kappa[5] == "18.9 [15.4, 21.4]"
    assert rows["| ginf3"].split(" | ")[4] == "= ginf2" and rows["| ginf3"].split(" | ")[6] == "= ginf2 |"
    assert rows["| scale"].startswith("| scale | - | - | - | - | - | ")
    assert "(mirror ESS 257, full ESS 33, scale ESS 1, **not trusted**:" in text
    assert "| joint | paper T1 |" not in render_report(dataclasses.replace(records, evidence_check=None))

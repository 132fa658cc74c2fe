"""Typed, versioned records: checked when written and when read, failing on the field by name."""

import json
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from bayestissue.analyses.records import MeasuredRecord, MeasuredResult, Tension
from bayestissue.io.records import RecordError, from_plain, read_record, to_plain, write_record


@dataclass(frozen=True)
class Inner:
    ci: tuple[float | None, float | None]
    flags: list[bool]


@dataclass(frozen=True)
class Demo:
    SCHEMA: ClassVar[str] = "bayestissue.demo"
    VERSION: ClassVar[int] = 2

    name: str
    n: int
    values: list[float]
    by_test: dict[str, Inner]
    pair: tuple[list[str], float]
    tension: Tension
    note: str | None


def _demo(**kw):
    base = dict(
        name="T1", n=3, values=np.array([1.0, np.inf, -np.inf]), by_test={"T1": Inner((None, 2.5), [True, False])},
        pair=(["mu", "kappa"], 15.7), tension=Tension(Q=np.float64(40897.4), df=11, p_value=0.0), note=None,
    )  # fmt: skip
    return Demo(**{**base, **kw})


def test_round_trip_keeps_every_value_and_type(tmp_path):
    path = write_record(tmp_path / "demo.json", _demo())
    doc = json.loads(path.read_text())
    assert doc["schema"] == "bayestissue.demo" and doc["version"] == 2
    assert doc["record"]["values"] == [1.0, "inf", "-inf"]  # JSON has no infinity: written as text
    back = read_record(path, Demo)
    assert back.values == [1.0, math.inf, -math.inf] and back.by_test["T1"] == Inner((None, 2.5), [True, False])
    assert back.pair == (["mu", "kappa"], 15.7) and back.tension == Tension(40897.4, 11, 0.0) and back.note is None
    assert isinstance(back.tension.Q, float) and from_plain(to_plain(back), Demo) == back


def test_a_wrong_value_fails_when_written_naming_its_path(tmp_path):
    with pytest.raises(RecordError, match=r"demo.json: Demo.by_test\['T1'\].flags\[1\]: expected true or false"):
        write_record(tmp_path / "demo.json", _demo(by_test={"T1": Inner((None, 2.5), [True, "no"])}))
    with pytest.raises(RecordError, match=r"Demo.n: expected an integer, got 2.5"):
        to_plain(_demo(n=2.5))
    with pytest.raises(RecordError, match=r"Demo.values\[0\]: expected a number, got True"):
        to_plain(_demo(values=[True]))
    with pytest.raises(RecordError, match=r"Demo.pair: expected a list of 2 entries"):
        to_plain(_demo(pair=(["mu"], 1.0, 2.0)))
    assert not (tmp_path / "demo.json").exists()  # nothing written


def test_a_missing_or_renamed_field_fails_in_the_stage_that_builds_the_record():
    """A stage builds its record with keywords: a field it forgets or misspells is refused at construction."""
    case = dict(name="t", material="m", engine="emcee", stretch=(1.0, 2.0), n=2, closed_form={}, least_squares={},
                posterior={}, converged=True, verdict="CONVERGED", seconds=1.0)  # fmt: skip
    MeasuredResult(**case)
    with pytest.raises(TypeError, match="seconds"):
        MeasuredResult(**{k: v for k, v in case.items() if k != "seconds"})
    with pytest.raises(TypeError, match="verdicts"):
        MeasuredResult(**{**case, "verdicts": case["verdict"]})
    with pytest.raises(TypeError, match="cases"):
        MeasuredRecord(mode="default")


def test_a_file_that_does_not_match_is_refused_when_read(tmp_path):
    path = write_record(tmp_path / "demo.json", _demo())
    doc = json.loads(path.read_text())

    def refused(change, match):
        d = json.loads(json.dumps(doc))
        change(d)
        (tmp_path / "bad.json").write_text(json.dumps(d))
        with pytest.raises(RecordError, match=match):
            read_record(tmp_path / "bad.json", Demo)

    refused(lambda d: d["record"].pop("tension"), r"bad.json: Demo.tension: expected a value .*got 'missing'")
    refused(lambda d: d["record"].update(nam=d["record"].pop("name")), r"field: expected one of .*'nam'.*did you mean")
    refused(lambda d: d["record"]["by_test"]["T1"].pop("ci"), r"Demo.by_test\['T1'\].ci: expected a value")
    refused(lambda d: d["record"].update(n="3"), r"Demo.n: expected an integer, got '3'")
    refused(lambda d: d.update(version=1), r"bad.json version: expected version 2 \(rerun the stage")
    refused(lambda d: d.update(schema="bayestissue.other"), r"bad.json schema: expected 'bayestissue.demo'")
    refused(lambda d: d["record"].pop("note"), r"Demo.note: expected a value")  # None is written, never implied
    (tmp_path / "text.json").write_text("not json")
    with pytest.raises(RecordError, match="text.json: expected a JSON record, got 'JSONDecodeError'"):
        read_record(tmp_path / "text.json", Demo)
    with pytest.raises(RecordError, match="absent.json: expected a bayestissue.demo record"):
        read_record(tmp_path / "absent.json", Demo)

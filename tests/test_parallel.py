"""Fan-out with a content-hash result cache: re-runs compute only what is unfinished.

Calls are counted through marker files written by the task itself (in the worker process).
"""

from __future__ import annotations

import os
import sys
import uuid
from dataclasses import dataclass
from pathlib import Path

import cloudpickle
import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.parallel import ResultCache, fan_out, projected_wall_time, start_client, task_key

# the workers cannot import this test module: ship its functions by value
cloudpickle.register_pickle_by_value(sys.modules[__name__])


def _square(x, *, markers: str):
    """Square ``x``; leave a marker file per call; fail while ``fail-<x>`` exists; die while
    ``die-<x>`` exists."""
    m = Path(markers)
    (m / f"call-{x}-{uuid.uuid4().hex}").touch()
    if (m / f"fail-{x}").exists():
        raise RuntimeError(f"planned failure for {x}")
    die = m / f"die-{x}"
    if die.exists():
        die.unlink()
        os._exit(1)  # the worker process dies mid-task
    return x * x


def _calls(markers: Path) -> dict[int, int]:
    out: dict[int, int] = {}
    for p in markers.glob("call-*"):
        x = int(p.name.split("-")[1])
        out[x] = out.get(x, 0) + 1
    return out


@pytest.fixture(scope="module")
def client():
    c = start_client(n_workers=2)
    yield c
    cluster = c.cluster
    c.close()
    cluster.close()


@dataclass(frozen=True)
class _Cfg:
    a: float
    b: tuple


def test_task_key_is_a_content_hash():
    k = task_key(_square, (np.arange(3.0),), {"markers": "m"})
    assert k == task_key(_square, (np.arange(3.0),), {"markers": "m"})
    assert k != task_key(_square, (np.arange(3.0) + 1e-12,), {"markers": "m"})
    assert k != task_key(_square, (np.arange(3),), {"markers": "m"})  # dtype matters
    assert k != task_key(_square, (np.arange(3.0),), {"markers": "m"}, salt="v2")
    assert task_key(len, ({"a": 1, "b": 2},)) == task_key(len, ({"b": 2, "a": 1},))
    assert task_key(len, (_Cfg(1.0, (1, 2)),)) != task_key(len, (_Cfg(1.0, (1, 3)),))


def test_result_cache_roundtrip(tmp_path):
    cache = ResultCache(tmp_path)
    assert "ab" * 32 not in cache
    cache.save("ab" * 32, {"x": np.arange(4)})
    assert "ab" * 32 in cache
    np.testing.assert_array_equal(cache.load("ab" * 32)["x"], np.arange(4))
    assert not list(tmp_path.rglob(".tmp-*"))


def test_serial_fan_out_reuses_cache(tmp_path):
    markers = tmp_path / "m"
    markers.mkdir()
    kw = {"markers": str(markers)}
    out = fan_out(_square, range(5), cache_dir=tmp_path / "c", client="serial", kwargs=kw)
    assert out == [0, 1, 4, 9, 16]
    out = fan_out(_square, [4, 1, 7], cache_dir=tmp_path / "c", client="serial", kwargs=kw)
    assert out == [16, 1, 49]
    assert _calls(markers) == {0: 1, 1: 1, 2: 1, 3: 1, 4: 1, 7: 1}  # only 7 was new


def test_interrupted_run_resumes_only_unfinished_tasks(tmp_path, client):
    markers = tmp_path / "m"
    markers.mkdir()
    kw = {"markers": str(markers)}
    for x in (2, 5):
        (markers / f"fail-{x}").touch()
    with pytest.raises(RuntimeError, match="planned failure"):
        fan_out(_square, range(8), cache_dir=tmp_path / "c", client=client, kwargs=kw)
    first = _calls(markers)
    assert set(first) == set(range(8))
    cached = {x for x in range(8) if task_key(_square, (x,), kw) in ResultCache(tmp_path / "c")}
    assert cached == set(range(8)) - {2, 5}
    for x in (2, 5):
        (markers / f"fail-{x}").unlink()
    out = fan_out(_square, range(8), cache_dir=tmp_path / "c", client=client, kwargs=kw)
    assert out == [x * x for x in range(8)]
    second = {x: n - first.get(x, 0) for x, n in _calls(markers).items()}
    assert {x for x, n in second.items() if n} == {2, 5}  # nothing finished was recomputed
    assert second[2] == second[5] == 1


def test_client_side_interrupt_then_resume(tmp_path, client):
    markers = tmp_path / "m"
    markers.mkdir()
    kw = {"markers": str(markers)}
    seen = []

    def stop_after_three(i, result):
        seen.append(i)
        if len(seen) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        fan_out(
            _square,
            range(10),
            cache_dir=tmp_path / "c",
            client=client,
            kwargs=kw,
            on_result=stop_after_three,
        )
    cache = ResultCache(tmp_path / "c")
    cached = {x for x in range(10) if task_key(_square, (x,), kw) in cache}
    assert len(cached) == 3
    client.cancel(list(client.futures))  # the abandoned futures of the interrupted run
    before = _calls(markers)
    out = fan_out(_square, range(10), cache_dir=tmp_path / "c", client=client, kwargs=kw)
    assert out == [x * x for x in range(10)]
    ran = {x for x, n in _calls(markers).items() if n > before.get(x, 0)}
    assert ran.isdisjoint(cached)


def test_lost_worker_is_survived_and_rerun_computes_nothing(tmp_path, client):
    markers = tmp_path / "m"
    markers.mkdir()
    kw = {"markers": str(markers)}
    (markers / "die-3").touch()
    out = fan_out(_square, range(6), cache_dir=tmp_path / "c", client=client, kwargs=kw)
    assert out == [x * x for x in range(6)]
    calls = _calls(markers)
    assert calls[3] >= 2  # the task that killed its worker was rescheduled
    client.wait_for_workers(2, timeout=30)
    out = fan_out(_square, range(6), cache_dir=tmp_path / "c", client=client, kwargs=kw)
    assert out == [x * x for x in range(6)]
    assert _calls(markers) == calls  # a re-run computes nothing


def test_bad_client_and_scheduler_are_rejected(tmp_path):
    with pytest.raises(ValidationError, match="client"):
        fan_out(_square, [1], cache_dir=tmp_path, client="threads", kwargs={"markers": str(tmp_path)})
    with pytest.raises(ValidationError, match="scheduler"):
        start_client("localhost")
    with pytest.raises(ValidationError, match="n_workers"):
        start_client(n_workers=0)


def test_the_projected_wall_time_is_the_longest_chain_of_tasks_one_worker_gets():
    assert [projected_wall_time(4, 10.0, w) for w in (1, 2, 3, 4, 64)] == [40.0, 20.0, 20.0, 10.0, 10.0]
    assert projected_wall_time(5, 10.0, 2, t_start=3.0) == 33.0

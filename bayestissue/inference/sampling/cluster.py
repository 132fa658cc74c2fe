"""Independent runs of one posterior as dask tasks: on a LocalCluster of this machine or on a running cluster.

The counterpart of :mod:`~bayestissue.inference.sampling.processes` for runs that should leave this machine (a lab's
16-64 cores, docs/cluster.md). The contract is the same: ``fn(problem, *a, report)`` for every ``a``, outputs in the
order of the arguments, and whatever a run passes to ``report`` reaches ``progress`` in this process.
:func:`run_runs` sends the runs of either engine (emcee ensembles, nested runs) to one or the other.

- **The problem travels pickled, once per task**, and each task unpickles its own copy: a calibration problem holds
  its forward model's scratch arrays and evaluation counters, which two tasks on one multi-threaded worker must not
  share (33 kB for the paper's T1 problem).
- **Progress** goes through the scheduler's event log: the run's ``report`` logs an event under a topic unique to
  this call (``Worker.log_event``), the client subscribes to it, and this process drains the events while it waits.
- **A run nobody waits for stops.** When this process ends (killed included) the scheduler releases its tasks, but
  a running task cannot be interrupted from outside; its next ``report`` sees that the worker no longer holds it and
  raises, so an abandoned run does not go on writing its checkpoint beside a resumed one.
- **Same seed, same run**: the runs' arithmetic is strict IEEE (:mod:`bayestissue.mechanics._jit`), so a run gives
  bit for bit what it gives in a forked process (tested).

Checkpoints are written by the workers at the paths the runs are given: on this machine's LocalCluster that is this
machine's disk; a remote cluster needs the run directory on a file system its workers share, or the runs restart
from scratch on ``--resume`` (their results still come back to this process).
"""

from __future__ import annotations

import numbers
import pickle
import queue as _queue
import time
import uuid
from collections.abc import Callable, Sequence

from bayestissue._validation import ValidationError
from bayestissue.inference.sampling.processes import run_in_processes
from bayestissue.parallel import LOCAL_CLUSTER as LOCAL
from bayestissue.parallel import RUN_TARGET_TEXT, is_run_target

__all__ = ["LOCAL", "RunAbandoned", "check_scheduler", "run_on_cluster", "run_runs"]


class RunAbandoned(RuntimeError):
    """Raised inside a task whose client has gone (the scheduler released it)."""


def check_scheduler(value) -> str | None:
    """``value`` if it names where runs can go (None, ``"local"`` or a scheduler address such as
    ``"tcp://host:8786"``), else a :class:`ValidationError`."""
    if value is None or is_run_target(value):
        return value
    raise ValidationError("scheduler", value, RUN_TARGET_TEXT)


def _plain(m):
    """A progress field as msgpack carries it (numpy scalars as Python numbers)."""
    if isinstance(m, bool | str) or m is None:
        return m
    return int(m) if isinstance(m, numbers.Integral) else float(m)


def _task(fn: Callable, blob: bytes, args: tuple, topic: str):
    from distributed import get_worker

    worker = get_worker()
    key = worker.get_current_task()

    def report(*msg):
        held = worker.state.tasks.get(key)
        if held is None or held.state in ("cancelled", "released", "forgotten"):
            raise RunAbandoned(f"task {key} was released by its client")
        worker.log_event(topic, [_plain(m) for m in msg])

    return fn(pickle.loads(blob), *args, report)


def run_on_cluster(
    scheduler: str, problem, fn: Callable, args: Sequence[tuple], n_workers: int, progress: Callable | None
) -> list:
    """``fn(problem, *a, report)`` for every ``a`` in ``args`` as dask tasks, on a new LocalCluster of ``n_workers``
    single-threaded workers (``scheduler = "local"``) or on the cluster at ``scheduler``; ``fn`` must be a
    module-level function. Returns the outputs in the order of ``args``; a task that raised raises here."""
    from bayestissue.parallel import start_client  # dask is imported only when runs go to a cluster

    check_scheduler(scheduler)
    client = start_client(None if scheduler == LOCAL else scheduler, n_workers=n_workers)
    started_here = scheduler == LOCAL
    events: _queue.Queue = _queue.Queue()
    topic = f"bayestissue-runs-{uuid.uuid4().hex}"
    try:
        client.subscribe_topic(topic, lambda event: events.put(event[1]))
        blob = pickle.dumps(problem, protocol=pickle.HIGHEST_PROTOCOL)
        futures = [client.submit(_task, fn, blob, tuple(a), topic, pure=False) for a in args]
        while not all(f.done() for f in futures):
            time.sleep(0.2)
            _drain(events, progress)
        results = client.gather(futures)
        _drain(events, progress)
        return results
    finally:
        client.unsubscribe_topic(topic)
        client.close()
        if started_here:
            client.cluster.close()


def run_runs(
    scheduler: str | None, problem, fn: Callable, args: Sequence[tuple], n_workers: int, progress: Callable | None
) -> list:
    """The runs ``fn(problem, *a, report)`` where ``scheduler`` says (``[sampler]``/``[nested] scheduler``): None, in
    ``n_workers`` forked processes of this machine (:func:`~bayestissue.inference.sampling.processes.run_in_processes`);
    otherwise as dask tasks (:func:`run_on_cluster`). Same contract, same outputs bit for bit."""
    if scheduler is None:
        return run_in_processes(problem, fn, args, n_workers, progress)
    return run_on_cluster(scheduler, problem, fn, args, n_workers, progress)


def _drain(events: _queue.Queue, progress: Callable | None) -> None:
    while True:
        try:
            msg = events.get_nowait()
        except _queue.Empty:
            return
        if progress is not None:
            progress(*msg)

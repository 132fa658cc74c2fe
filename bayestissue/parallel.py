"""Fan many independent runs out over dask.distributed, with results cached on disk by content hash.

Bootstrap replicates, loading-rate scenarios, profile likelihoods and multi-starts are independent
tasks. :func:`fan_out` runs ``func(*args)`` for every argument tuple of a list, on a dask
``LocalCluster`` by default (one single-threaded worker process per core), on a running cluster
given its scheduler address, or serially.

Every task is keyed by a SHA-256 hash of the function's module and qualified name and of its
arguments (:func:`task_key`; arrays hash by dtype, shape and bytes, dicts by sorted items,
dataclasses by their fields). The client writes each result to ``<cache_dir>/<key[:2]>/<key>.pkl``
(atomically: temporary file, then ``os.replace``) as soon as it arrives, so

* a re-run recomputes nothing that already finished;
* an interrupted run (Ctrl-C, a crashed client, a task that raised) resumes with only the unfinished
  tasks;
* a worker that dies mid-task is replaced by the dask nanny and its tasks are rescheduled by the
  scheduler (up to ``distributed.scheduler.allowed-failures`` times); finished results already on
  disk are never lost.

Results are written by the client, so a remote cluster does not need a shared file system. The key
hashes the function's name, not its body: pass a ``salt`` that changes with the code (the studies use
a hash of the package's source, ``studies/identifiability.py: code_salt``) or clear the cache dir.

See ``docs/cluster.md`` for pointing the fan-out at a real cluster.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import math
import os
import pickle
import tempfile
import uuid
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError

__all__ = [
    "task_key",
    "ResultCache",
    "LOCAL_CLUSTER",
    "RUN_TARGET_TEXT",
    "fan_out",
    "is_run_target",
    "is_scheduler_address",
    "projected_wall_time",
    "start_client",
]

_log = logging.getLogger(__name__)


# ------------------------------------------------------------------------------------------
# content hashing
def _update(h, obj) -> None:
    """Feed a canonical byte representation of ``obj`` into hash ``h`` (type-tagged,
    order-stable)."""
    if obj is None or isinstance(obj, bool | int | float | complex | str | bytes):
        h.update(f"{type(obj).__name__}:{obj!r};".encode())
    elif isinstance(obj, np.generic):
        _update(h, obj.item())
    elif isinstance(obj, np.ndarray):
        a = np.ascontiguousarray(obj)
        h.update(f"nd:{a.dtype.str}:{a.shape};".encode())
        if a.dtype.hasobject:
            for x in a.ravel():
                _update(h, x)
        else:
            h.update(a.tobytes())
    elif isinstance(obj, list | tuple):
        h.update(f"{type(obj).__name__}[{len(obj)}];".encode())
        for x in obj:
            _update(h, x)
    elif isinstance(obj, dict):
        h.update(f"dict[{len(obj)}];".encode())
        for k in sorted(obj, key=repr):
            _update(h, k)
            _update(h, obj[k])
    elif isinstance(obj, set | frozenset):
        h.update(f"set[{len(obj)}];".encode())
        for x in sorted(obj, key=repr):
            _update(h, x)
    elif isinstance(obj, Path):
        _update(h, ("path", str(obj)))
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        h.update(f"dc:{type(obj).__module__}.{type(obj).__qualname__};".encode())
        for f in dataclasses.fields(obj):
            _update(h, f.name)
            _update(h, getattr(obj, f.name))
    elif callable(obj) and hasattr(obj, "__qualname__"):
        h.update(f"fn:{getattr(obj, '__module__', '')}.{obj.__qualname__};".encode())
    else:  # last resort: the pickle (deterministic for plain objects)
        h.update(b"pk:" + pickle.dumps(obj, protocol=4))


def task_key(func: Callable, args: Sequence = (), kwargs: dict | None = None, *, salt: str = "") -> str:
    """Content hash of a task: the function's module and qualified name, its arguments and a
    ``salt``.

    Parameters
    ----------
    func : the task function (a module-level function or a picklable callable object).
    args, kwargs : its arguments.
    salt : extra text (e.g. a code version) mixed into the hash.

    Returns
    -------
    key : 64 hex digits (SHA-256).
    """
    h = hashlib.sha256()
    name = getattr(func, "__qualname__", None)
    if name is None:  # a callable instance: its class name and its state
        name = type(func).__qualname__
        _update(h, ("callable", type(func).__module__, name))
        _update(h, func.__dict__ if hasattr(func, "__dict__") else repr(func))
    else:
        _update(h, ("func", getattr(func, "__module__", ""), name))
    _update(h, tuple(args))
    _update(h, dict(kwargs or {}))
    _update(h, salt)
    return h.hexdigest()


# ------------------------------------------------------------------------------------------
class ResultCache:
    """Pickled results on disk, one file per task key: ``<root>/<key[:2]>/<key>.pkl``.

    Writes are atomic (temporary file in the same folder, then ``os.replace``), so a killed process
    never leaves a half-written result behind.
    """

    def __init__(self, root: str | Path):
        self.root = Path(root)

    def path(self, key: str) -> Path:
        return self.root / key[:2] / f"{key}.pkl"

    def __contains__(self, key: str) -> bool:
        return self.path(key).is_file()

    def load(self, key: str):
        with self.path(key).open("rb") as fh:
            return pickle.load(fh)

    def save(self, key: str, value) -> Path:
        p = self.path(key)
        p.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=".tmp-", suffix=".pkl")
        try:
            with os.fdopen(fd, "wb") as fh:
                pickle.dump(value, fh, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, p)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return p


# ------------------------------------------------------------------------------------------
def _call(func, args, kwargs):
    return func(*args, **kwargs)


#: Where runs go when they go to "a cluster on this machine" (``[nested] scheduler = "local"``): a LocalCluster.
LOCAL_CLUSTER = "local"


def is_scheduler_address(value) -> bool:
    """Whether ``value`` reads as a dask scheduler address: a protocol, ``://`` and a host (``"tcp://host:8786"``)."""
    if not isinstance(value, str):
        return False
    protocol, sep, host = value.partition("://")
    return bool(protocol and sep and host)


def is_run_target(value) -> bool:
    """Whether ``value`` names where runs can go: :data:`LOCAL_CLUSTER` or a scheduler address (``[nested]
    scheduler``; None, the forked processes, is the caller's default and not checked here)."""
    return value == LOCAL_CLUSTER or is_scheduler_address(value)


#: What :func:`is_run_target` accepts, as the error messages say it.
RUN_TARGET_TEXT = f'"{LOCAL_CLUSTER}" or a dask scheduler address like "tcp://host:8786"'


def start_client(scheduler: str | None = None, *, n_workers: int | None = None):
    """Return a dask ``Client``: connected to ``scheduler`` (``"tcp://host:8786"``) or to a new
    LocalCluster.

    The LocalCluster has ``n_workers`` single-threaded worker processes (default: the number of
    usable cores) so that numba/numpy code in one task never competes with another for a core. Close
    it with ``client.close(); client.cluster.close()`` (the cluster only if this function started
    it).
    """
    from dask.distributed import Client, LocalCluster

    if scheduler:
        if not is_scheduler_address(scheduler):
            raise ValidationError(
                "scheduler",
                scheduler,
                "a scheduler address like 'tcp://host:8786'",
                "or None for a LocalCluster",
            )
        return Client(scheduler)
    if n_workers is None:
        n_workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    n_workers = int(n_workers)
    if n_workers < 1:
        raise ValidationError("n_workers", n_workers, "an integer >= 1")
    # dashboard on a free port: a fixed one (8787) makes two clusters on one machine (two studies, CI beside a
    # study) fail to start
    cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=":0")
    return Client(cluster)


def fan_out(
    func: Callable,
    arg_list: Iterable,
    *,
    cache_dir: str | Path,
    client=None,
    kwargs: dict | None = None,
    salt: str = "",
    on_result: Callable | None = None,
) -> list:
    """Run ``func(*args, **kwargs)`` for each ``args`` in ``arg_list``; reuse cached results; cache
    new ones.

    Parameters
    ----------
    func : module-level function (or picklable callable) of the task; must be deterministic in its
        arguments (pass a seed as an argument for stochastic tasks).
    arg_list : iterable of argument tuples (a non-tuple item is taken as a single argument).
    cache_dir : folder of the result cache (:class:`ResultCache`).
    client : a ``dask.distributed.Client``, or ``"serial"`` to run in this process (debugging, tiny
        jobs). ``None`` starts a LocalCluster for this call only (see :func:`start_client`) if any
        task is missing.
    kwargs : keyword arguments shared by every task (part of every key).
    salt : text mixed into every key (bump it when ``func``'s code changes).
    on_result : optional ``on_result(i, result)`` called as each result arrives (e.g. a progress
        bar).

    Returns
    -------
    results : list in the order of ``arg_list``.

    Raises ------ ValidationError for a bad ``client``; otherwise the first exception raised by a
    task, after every task that finished has been cached (a re-run then computes only the unfinished
    ones).
    """
    kwargs = dict(kwargs or {})
    args_all = [a if isinstance(a, tuple) else (a,) for a in arg_list]
    cache = ResultCache(cache_dir)
    keys = [task_key(func, a, kwargs, salt=salt) for a in args_all]
    results: list = [None] * len(args_all)
    todo: dict[str, list[int]] = {}
    for i, k in enumerate(keys):
        if k in cache:
            results[i] = cache.load(k)
            if on_result is not None:
                on_result(i, results[i])
        else:
            todo.setdefault(k, []).append(i)  # identical tasks run once
    _log.info(
        "fan_out %s: %d tasks, %d cached",
        getattr(func, "__qualname__", func),
        len(keys),
        len(keys) - len(todo),
    )
    if not todo:
        return results

    def _store(k, value):
        cache.save(k, value)
        for i in todo[k]:
            results[i] = value
            if on_result is not None:
                on_result(i, value)

    if isinstance(client, str):
        if client != "serial":
            raise ValidationError("client", client, "a dask Client, 'serial' or None")
        for k, idx in todo.items():
            _store(k, func(*args_all[idx[0]], **kwargs))
        return results

    own = client is None
    if own:
        client = start_client()
    try:
        from dask.distributed import as_completed

        name = getattr(func, "__name__", type(func).__name__)
        run = uuid.uuid4().hex[:8]  # a fresh dask key per call: an erred key of an earlier call is not reused
        futures = {}
        for k, idx in todo.items():
            fut = client.submit(_call, func, args_all[idx[0]], kwargs, key=f"{name}-{k[:16]}-{run}", pure=False)
            futures[fut] = k
        first_error = None
        for fut in as_completed(list(futures)):
            k = futures[fut]
            if fut.status == "error":
                if first_error is None:
                    first_error = fut.exception()
                fut.release()
                continue
            try:
                _store(k, fut.result())
            except Exception as exc:  # pragma: no cover - e.g. a cancelled future
                first_error = first_error or exc
            fut.release()
        futures.clear()
        if first_error is not None:
            raise first_error
    finally:
        if own:
            cluster = client.cluster
            client.close()
            cluster.close()
    return results


def projected_wall_time(n_tasks: int, t_task: float, n_workers: int, t_start: float = 0.0) -> float:
    r"""Wall time of ``n_tasks`` independent tasks of mean time ``t_task`` on ``n_workers`` workers when no task is
    split: the start-up plus the longest chain of tasks one worker gets,

    .. math:: t(W) \approx t_\text{start} + \lceil R / W \rceil \, \bar t_\text{task}

    (beyond W = R workers only more tasks use the cores; docs/cluster.md). ``t_task`` should be measured with every
    worker busy: tasks sharing a machine slow each other."""
    return t_start + math.ceil(n_tasks / n_workers) * t_task

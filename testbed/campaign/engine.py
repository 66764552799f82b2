"""The one engine that runs the cases of a sweep or campaign: Dask distributed.

`Engine()` starts a local cluster inside the command, one single-threaded worker process per
core (or `workers`); `Engine(scheduler="tcp://HOST:PORT")` submits to a hand-started cluster
(docs/campaigns.md, "Several machines"). Starting, reaching and closing a cluster within bounds,
whatever signal comes: testbed.campaign.cluster. `results(fn, tasks)` yields (args, fn(*args))
as each case finishes, or (args, CaseLost) for one whose worker died running it twice, that ran
past its timeout twice, or that no worker could take (testbed.campaign.dispatch). Ctrl-C
cancels the cases out; leaving the `with` block closes the local cluster.
"""

from __future__ import annotations

import os
import signal
import threading
from typing import Any, Callable, Iterable, Iterator

from distributed.diagnostics.plugin import WorkerPlugin

from testbed.campaign import cluster as dask_cluster
from testbed.campaign.dispatch import CaseDispatch
from testbed.errors import InputError

NO_WORKER_S = 2 * dask_cluster.START_TIMEOUT_S  # no worker at all this long: the cases left cannot run
# The local scheduler reports a dead worker's task at once (it would otherwise run it again
# itself, possibly on a worker that is busy): the command retries it, one task per worker.
# Its workers are forked from a fork server that ignores SIGINT (testbed.campaign.cluster).
LOCAL_CONFIG = {"distributed.scheduler.allowed-failures": 0, "distributed.worker.multiprocessing-method": "forkserver"}


def _warm_up() -> str:
    """Run once in every worker: import the testbed and register its systems and stages, so
    that the first case on a worker does not pay for it."""
    import warnings

    from testbed.plugins import discover

    warnings.simplefilter("ignore")  # as in the command's own process (testbed.cli.main): none printed raw
    discover()
    return "ready"


def _load_plugins(entries: list[str], base: str) -> tuple[str, str] | None:
    """Run in a worker: import the plug-ins; (field, reason) if one cannot be (an InputError
    does not pickle: its arguments are not its constructor's)."""
    from pathlib import Path

    from testbed.plugins import load_plugins

    try:
        load_plugins(entries, Path(base))
    except InputError as exc:
        return exc.field, exc.reason
    return None


class LocalWorker(WorkerPlugin):
    """Set up every worker process of the local cluster, a restarted one too: Ctrl-C on the
    terminal reaches the whole process group, so the workers ignore it and the command stops
    them in order; and the testbed is loaded before the first case."""

    def setup(self, worker) -> None:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        _warm_up()


class Engine:
    """A cluster to run cases on: `workers` local processes (checked here: 1 ... max_workers(),
    default one per core), or the cluster of the scheduler at `scheduler`; started by `with`."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None):
        if scheduler is not None and workers is not None:
            raise InputError("--workers", "sizes the local cluster; with --scheduler the cluster's own workers run the cases")
        self.workers = dask_cluster.checked_workers(workers) if workers is not None else os.cpu_count() or 1
        self.scheduler = scheduler
        self.client = self.cluster = self.config = None

    def at_most(self, cases: int) -> bool:
        """No more local workers than `cases` (an idle worker only costs its start); whether
        that started fewer than asked for."""
        clamped = self.scheduler is None and self.workers > cases
        self.workers = min(self.workers, cases)
        return clamped

    def __enter__(self) -> "Engine":
        import dask

        if self.scheduler is None:
            self.config = dask.config.set(LOCAL_CONFIG)  # for the cluster's life: a restarted worker reads it too
            try:
                self.cluster, self.client = dask_cluster.start_local(self.workers)
            except BaseException:
                self.__exit__(None, None, None)
                raise
        else:
            self.client = dask_cluster.connect(self.scheduler)
        try:
            if self.cluster is not None:
                self.client.register_plugin(LocalWorker())
            else:
                self.client.run(_warm_up)
        except Exception as exc:  # noqa: BLE001  (a worker that cannot import the testbed)
            self.__exit__(None, None, None)
            raise InputError("--scheduler" if self.scheduler else "--workers",
                             f"a worker cannot load the testbed: {type(exc).__name__}: {exc}") from None
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def __exit__(self, *exc_info) -> None:
        client, cluster, self.client, self.cluster = self.client, self.cluster, None, None
        dask_cluster.close(client, cluster)
        if self.config is not None:
            self.config.__exit__(None, None, None)
            self.config = None

    def load_plugins(self, entries: list[str], base: str) -> None:
        """Import a scenario's plug-ins (testbed.plugins.load_plugins) in every worker now, so
        that one a worker cannot load is bad input naming the plug-in and the worker, before any
        case runs (not an error row in every case)."""
        try:
            failures = self.client.run(_load_plugins, entries, base)
        except Exception as exc:  # noqa: BLE001  (a worker gone meanwhile, a comm error)
            raise InputError("plugins", f"the workers cannot load {entries}: {type(exc).__name__}: {exc}") from None
        for address, failure in sorted(failures.items()):
            if failure is not None:
                field, reason = failure
                raise InputError(field, f"worker {address} cannot load it: {reason}")

    @property
    def worker_count(self) -> int:
        return len(self.client.scheduler_info(n_workers=-1)["workers"])

    def results(self, fn: Callable, tasks: Iterable[tuple], name: Callable[[tuple], str] = str,
                timeout_s: Callable[[tuple], float | None] = lambda args: None,
                split: Callable[[tuple], list[tuple]] = lambda args: []) -> Iterator[tuple[tuple, Any]]:
        """(args, fn(*args) or CaseLost) for every argument tuple in `tasks`, in the order they
        finish; name(args) names the task (uniquely) on the scheduler; a try may last
        timeout_s(args); a task that split(args) divides runs as those parts instead of a retry
        (testbed.campaign.dispatch)."""
        return CaseDispatch(self.client, self.cluster is not None, fn, tasks, name, timeout_s,
                            NO_WORKER_S, split).outcomes()

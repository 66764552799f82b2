"""The one engine that runs the cases of a sweep or campaign: Dask distributed.

`Engine()` starts a local cluster inside the command, one single-threaded worker process per
core (or `workers`); `Engine(scheduler="tcp://HOST:PORT")` submits to a cluster started with
`dask scheduler` and `dask worker` (README, "Several machines"), refused as bad input
when nothing answers there within SCHEDULER_TIMEOUT_S or no worker joins.

`results(fn, tasks)` runs fn(*args) for every argument tuple and yields (args, outcome) as each
finishes: fn's return value, or `WorkerDied` when the worker process running it died twice.
The command hands out one task per worker thread, and the next when one finishes, so no task
waits on a worker behind another: a dying worker takes only the case it was running with it
(the scheduler fails every task a dead worker was processing). The command hands that case
out once more (the local scheduler reports the death at once, allowed-failures 0; another
scheduler first retries by its own setting, Dask's default 3 times). Results are fetched in
the background as tasks finish and released once taken, and a worker gets its next task only
after that, so a worker that dies holds no finished result that would have to be computed
again. Ctrl-C (or any exception in the caller's loop) cancels the cases out; leaving the
`with` block closes the local cluster, stopping them. On an external cluster the ones running
go on to their end (a worker thread cannot be stopped), their results unused.
"""

from __future__ import annotations

import logging
import os
import signal
import threading
import uuid
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator

from distributed.diagnostics.plugin import WorkerPlugin

from testbed.errors import InputError

SCHEDULER_TIMEOUT_S = 5.0     # connecting to --scheduler, and again for its first worker
RETRIES = 1  # a case whose worker died runs once more
# The local scheduler reports a dead worker's task at once (it would otherwise run it again
# itself, possibly on a worker that is busy): the command retries it, one task per worker.
LOCAL_CONFIG = {"distributed.scheduler.allowed-failures": 0}


@dataclass(frozen=True)
class WorkerDied:
    """The outcome of a task whose worker process died (twice, on the local cluster)."""

    reason: str


def _warm_up() -> str:
    """Run once in every worker: import the testbed and register its systems and stages, so
    that the first case on a worker does not pay for it."""
    from testbed.plugins import discover

    discover()
    return "ready"


class LocalWorker(WorkerPlugin):
    """Set up every worker process of the local cluster, a restarted one too: Ctrl-C on the
    terminal reaches the whole process group, so the workers ignore it and the command stops
    them in order; and the testbed is loaded before the first case."""

    def setup(self, worker) -> None:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        _warm_up()


class Engine:
    def __init__(self, workers: int | None = None, scheduler: str | None = None):
        self.workers = workers or os.cpu_count() or 1
        self.scheduler = scheduler
        self.client = self.cluster = None

    def __enter__(self) -> "Engine":
        import dask
        from distributed import Client, LocalCluster

        if self.scheduler is None:
            with dask.config.set(LOCAL_CONFIG):
                self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True,
                                            dashboard_address=None, silence_logs=logging.CRITICAL)
                self.client = Client(self.cluster)
        else:
            self.client = _connect(self.scheduler)
        try:
            if self.cluster is not None:
                self.client.register_plugin(LocalWorker())
            else:
                self.client.run(_warm_up)
        except Exception as exc:  # noqa: BLE001  (a worker that cannot import the testbed)
            self.__exit__(None, None, None)
            raise InputError("--scheduler" if self.scheduler else "workers",
                             f"a worker cannot load the testbed: {type(exc).__name__}: {exc}") from None
        return self

    def __exit__(self, *exc_info) -> None:
        for part in (self.client, self.cluster):
            if part is not None:
                try:
                    part.close()
                except Exception:  # noqa: BLE001  (closing after an interrupt: best effort)
                    pass
        self.client = self.cluster = None

    @property
    def worker_count(self) -> int:
        return len(self.client.scheduler_info(n_workers=-1)["workers"])

    def results(self, fn: Callable, tasks: Iterable[tuple], name: Callable[[tuple], str] = str
                ) -> Iterator[tuple[tuple, Any]]:
        """(args, fn(*args) or WorkerDied) for every argument tuple in `tasks`, in the order they
        finish; name(args) names the task (uniquely) on the scheduler. At most one task per
        worker thread is out at a time; a task whose worker died is handed out RETRIES times
        more (module doc)."""
        from distributed import KilledWorker, as_completed

        batch = uuid.uuid4().hex[:8]  # keys stay unique on a scheduler shared by several campaigns
        waiting, retry, running, deaths = iter(tasks), [], {}, {}
        finished = as_completed([], with_results=True, raise_errors=False)

        def hand_out() -> None:
            while len(running) < self.slots():
                args = retry.pop() if retry else next(waiting, None)
                if args is None:
                    return
                key = f"case-{batch}-{name(args)}-{deaths.get(name(args), 0)}"
                future = self.client.submit(fn, *args, key=key, pure=False)
                running[future] = args
                finished.add(future)

        hand_out()
        try:
            for future, outcome in finished:
                args, failed = running.pop(future), future.status == "error"
                future.release()
                if isinstance(outcome, BaseException):  # cancelled: the cluster went away
                    raise outcome
                if failed:  # outcome is (type, exception, traceback)
                    if not isinstance(outcome[1], KilledWorker):
                        raise outcome[1]
                    deaths[name(args)] = deaths.get(name(args), 0) + 1
                    if deaths[name(args)] <= RETRIES:
                        retry.append(args)
                        outcome = None
                    else:
                        outcome = WorkerDied(f"the worker process died running it, {deaths[name(args)]} times")
                hand_out()
                if outcome is not None:
                    yield args, outcome
        finally:
            if running:
                self.client.cancel(list(running))

    def slots(self) -> int:
        """How many tasks may be out: the cluster's worker threads now (at least 1)."""
        return max(1, sum(self.client.nthreads().values()))


def _connect(address: str):
    """A client of the scheduler at `address` with at least one worker; bad input otherwise."""
    from distributed import Client

    try:
        client = Client(address, timeout=SCHEDULER_TIMEOUT_S)
    except Exception as exc:  # noqa: BLE001  (refused, timed out, or not a Dask scheduler at all)
        raise InputError("--scheduler", f"no Dask scheduler answers at {address} within "
                                        f"{SCHEDULER_TIMEOUT_S:g} s ({type(exc).__name__}: {exc})") from None
    try:
        client.wait_for_workers(1, timeout=SCHEDULER_TIMEOUT_S)
    except Exception:  # noqa: BLE001
        client.close()
        raise InputError("--scheduler", f"the Dask scheduler at {address} has no worker "
                                        f"(none joined within {SCHEDULER_TIMEOUT_S:g} s)") from None
    return client

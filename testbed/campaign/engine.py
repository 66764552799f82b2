"""The one engine that runs the cases of a sweep or campaign: Dask distributed.

`Engine()` starts a local cluster inside the command, one single-threaded worker process per
core (or `workers`); `Engine(scheduler="tcp://HOST:PORT")` submits to a cluster started with
`dask scheduler` and `dask worker` (docs/campaigns.md, "Several machines"). Starting, reaching and
closing a cluster, within bounds and whatever signal comes: testbed.campaign.cluster.

`results(fn, tasks)` runs fn(*args) for every argument tuple and yields (args, outcome) as each
finishes: fn's return value, or `CaseLost` when the worker process running it died twice, or
it ran past its timeout twice.
The command places the tasks itself, DEPTH per worker thread, and the next as one finishes.
DEPTH is 1: when a worker dies, the task out on it is the one it was running. (With a second
task waiting on the worker, one that had finished but whose result died with the worker was
the oldest out and was blamed: 1 run in 3 of tests/test_dask_cluster.py's worker death.)
With more threads a worker runs its tasks oldest first, so the oldest task out on it when the
first of its tasks is reported dead is the one that killed it (the others may be reported in
any order): that case is handed out once more (the
local scheduler reports every task of a dead worker at once, allowed-failures 0; another
scheduler first retries them by its own setting, Dask's default 3 times), then reported as
an error row; the one that waited behind it goes back in the queue, not counted. Results are
fetched in the background as tasks finish and released once taken. A task placed on a worker
that died meanwhile can wait on the scheduler for that worker forever ('no-worker'); when no
task has finished for STALL_S the command asks the scheduler, and hands such tasks out again.
A task out for longer than timeout_s(args) (testbed.campaign.case_timeout), counted from when its try
was first handed out, is given up: on the local cluster its worker process is ended from its
event loop (a thread running a task cannot be stopped; the nanny starts another), and a task
out on a worker so ended is not blamed for its death; on an external cluster that thread
runs on and this command gives it nothing more. It is handed out RETRIES times more, then a
CaseLost. Cases that no worker can take (every thread so held, or no worker for NO_WORKER_S)
become CaseLost rather than wait forever.
Ctrl-C (or any exception in the caller's loop) cancels the cases out; leaving the `with`
block closes the local cluster, stopping them. On an external cluster the ones running go on
to their end (a worker thread cannot be stopped), their results unused.
"""

from __future__ import annotations

import collections
import os
import signal
import threading
import time
import uuid
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator

from distributed.diagnostics.plugin import WorkerPlugin

from testbed.campaign import cluster as dask_cluster
from testbed.errors import InputError

RETRIES = 1  # a case whose worker died runs once more
# No task has finished for this long: ask the scheduler whether any task out is stranded
# (placed on a worker that died meanwhile, it waits in 'no-worker' for that worker forever).
STALL_S = 2.0
POLL_S = 0.05
DEPTH = 1    # tasks out per worker thread: the one running (module doc)
NO_WORKER_S = 2 * dask_cluster.START_TIMEOUT_S  # no worker at all this long: the cases left cannot run
# The local scheduler reports a dead worker's task at once (it would otherwise run it again
# itself, possibly on a worker that is busy): the command retries it, one task per worker.
# Its workers are forked from a fork server that ignores SIGINT (testbed.campaign.cluster).
LOCAL_CONFIG = {"distributed.scheduler.allowed-failures": 0, "distributed.worker.multiprocessing-method": "forkserver"}


@dataclass(frozen=True)
class CaseLost:
    """The outcome of a task that gave no result: its worker process died running it (twice,
    on the local cluster), or it ran past its timeout twice."""

    reason: str


def _times(count: int) -> str:
    return {1: "once", 2: "twice"}.get(count, f"{count} times")


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
    def __init__(self, workers: int | None = None, scheduler: str | None = None):
        self.workers = workers or os.cpu_count() or 1
        self.scheduler = scheduler
        self.client = self.cluster = self.config = None

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
                timeout_s: Callable[[tuple], float | None] = lambda args: None) -> Iterator[tuple[tuple, Any]]:
        """(args, fn(*args) or CaseLost) for every argument tuple in `tasks`, in the order they
        finish; name(args) names the task (uniquely) on the scheduler. Each worker thread has
        DEPTH tasks out; when a worker dies, its oldest task is the one
        that killed it, handed out RETRIES times more, and the others go back in the queue;
        a task out for longer than timeout_s(args) is given up and handed out RETRIES times
        more (module doc)."""
        from distributed import KilledWorker, as_completed

        batch = uuid.uuid4().hex[:8]  # keys stay unique on a scheduler shared by several campaigns
        pending = collections.deque(tasks)  # a case handed out again goes first
        deaths: dict[str, int] = {}         # name -> how often a worker died running it
        overruns: dict[str, int] = {}       # name -> how often it ran past its timeout
        stuck: collections.Counter = collections.Counter()  # external worker -> threads held by a task given up
        ended: set[str] = set()             # local workers this command killed (the scheduler may list them a while)
        attempt: dict[str, float] = {}      # name -> when its current try was first handed out (kept when stranded)
        out: dict = {}                      # future -> (args, worker address, when handed out [monotonic s])
        queues: dict[str, list] = {}        # worker address -> its futures, oldest first
        blame: dict = {}                    # future out on a worker that died -> whether it was the oldest
        finished = as_completed([], with_results=True, raise_errors=False)
        last_finish = time.monotonic()

        def hand_out() -> None:
            for address, worker in self.client.scheduler_info()["workers"].items():
                if address in ended:
                    continue
                queue = queues.setdefault(address, [])
                while pending and len(queue) + stuck[address] < DEPTH * worker["nthreads"]:
                    args = pending.popleft()
                    key = f"{name(args)}-{batch}-{uuid.uuid4().hex[:8]}"  # a case handed out again gets a new key
                    future = self.client.submit(fn, *args, key=key, pure=False, workers=[address],
                                                allow_other_workers=True)
                    out[future] = (args, address, time.monotonic())
                    attempt.setdefault(name(args), time.monotonic())
                    queue.append(future)
                    finished.add(future)

        def hand_back_stranded() -> None:
            """Tasks out for longer than STALL_S that the scheduler cannot run go back in the
            queue (not counted as a death): a new key, placed on a worker that is there."""
            old = [f for f, (_, _, handed) in out.items() if time.monotonic() - handed > STALL_S]
            if not old:
                return
            try:
                stranded = set(self.client.run_on_scheduler(_stranded, [f.key for f in old]))
            except Exception:  # noqa: BLE001  (a scheduler that runs no code of ours: wait on)
                return
            for future in [f for f in old if f.key in stranded]:
                args, address, _ = out.pop(future)
                blame.pop(future, None)
                if future in queues.get(address, ()):
                    queues[address].remove(future)
                self.client.cancel([future])
                pending.appendleft(args)

        def give_up_overdue() -> Iterator[tuple[tuple, CaseLost]]:
            """Tasks out for longer than their timeout: cancelled, and their worker process
            killed on the local cluster (its thread cannot be stopped otherwise; its nanny starts
            it again), or left to its end on an external one, where this command hands that
            thread nothing more. Handed out again RETRIES times, then a CaseLost."""
            now = time.monotonic()
            for future, (args, address, handed) in list(out.items()):
                bound = timeout_s(args)
                if bound is None or now - attempt.get(name(args), handed) <= bound:
                    continue
                attempt.pop(name(args), None)
                out.pop(future)
                blame.pop(future, None)
                if future in queues.get(address, ()):
                    queues[address].remove(future)
                self.client.cancel([future])
                if self.cluster is not None:
                    queues.pop(address, None)
                    ended.add(address)
                    self.client.run(_end_worker_process, workers=[address], wait=False)
                else:
                    stuck[address] += 1
                overruns[name(args)] = overruns.get(name(args), 0) + 1
                if overruns[name(args)] <= RETRIES:
                    pending.appendleft(args)
                else:
                    yield args, CaseLost(f"ran longer than the case timeout of {bound:g} s, "
                                         f"{_times(overruns[name(args)])}")

        def why_none_can_run() -> str | None:
            """Why no pending task can run, if none can: every worker thread held by a task given
            up (on an external cluster), or no worker at all for longer than NO_WORKER_S."""
            info = self.client.scheduler_info()["workers"]
            if info and all(stuck[a] >= w["nthreads"] for a, w in info.items()):
                return "not run: every worker thread is still running a case that ran past its timeout"
            if not info and time.monotonic() - last_finish > NO_WORKER_S:
                return f"not run: the cluster had no worker for {NO_WORKER_S:g} s"
            return None

        try:
            while pending or out:
                hand_out()
                if not out:  # every worker died and none is back yet, or every thread is held
                    why = why_none_can_run()
                    while why and pending:
                        args = pending.popleft()
                        tried = (f"ran longer than the case timeout of {timeout_s(args):g} s, once; then "
                                 if overruns.get(name(args)) else "")
                        yield args, CaseLost(tried + why)
                    time.sleep(0.1)
                    continue
                if not finished.has_ready():  # a bounded wait: a task can be stranded (hand_back_stranded)
                    _wait_a_little(finished)
                    yield from give_up_overdue()
                    if time.monotonic() - last_finish > STALL_S:
                        hand_back_stranded()
                        last_finish = time.monotonic()
                    continue
                future, outcome = next(finished)
                if future not in out:  # one handed out again (hand_back_stranded): its cancellation
                    continue
                last_finish = time.monotonic()
                args, address, _ = out.pop(future)
                attempt.pop(name(args), None)  # its try is over: done, or handed out again as a new one
                failed = future.status == "error"
                future.release()
                if isinstance(outcome, BaseException):  # cancelled: the cluster went away
                    raise outcome
                if failed and isinstance(outcome[1], KilledWorker) and future not in blame:
                    # the first of a dead worker's tasks to be reported: the oldest out on it then
                    # is the one that killed it, whatever order the others are reported in
                    dead = queues.pop(address, [])
                    blame.update({f: i == 0 for i, f in enumerate(dead)})
                culprit = blame.pop(future, False) and address not in ended  # not one this command killed
                if future in queues.get(address, ()):
                    queues[address].remove(future)
                if failed:  # outcome is (type, exception, traceback)
                    if not isinstance(outcome[1], KilledWorker):
                        raise outcome[1]
                    if culprit:
                        deaths[name(args)] = deaths.get(name(args), 0) + 1
                    if not culprit or deaths[name(args)] <= RETRIES:  # one that waited behind it is not to blame
                        pending.appendleft(args)
                        continue
                    outcome = CaseLost(f"the worker process died running it, {deaths[name(args)]} times")
                yield args, outcome
        finally:
            if out:
                self.client.cancel(list(out))


async def _end_worker_process() -> None:
    """Run on a worker's event loop (`client.run`, beside its busy thread): its process ends, and
    its nanny starts another."""
    os._exit(1)


def _wait_a_little(finished) -> None:
    """Until a task of `finished` (distributed.as_completed) finishes, or POLL_S: woken by its
    own condition as as_completed's blocking `next` is, so a finished case is taken at once."""
    condition = getattr(finished, "thread_condition", None)
    if condition is None:
        time.sleep(POLL_S)
        return
    with condition:
        if not finished.has_ready():
            condition.wait(timeout=POLL_S)


def _stranded(keys: list, dask_scheduler=None) -> list:
    """Of `keys`, those the scheduler cannot run (run on the scheduler): unknown to it, or in
    'no-worker', waiting for a worker that is no longer there, while another one runs. (With no
    worker running, as while restarted ones start, a task handed out again would wait the same.)"""
    tasks = dask_scheduler.tasks
    waiting = ("no-worker", "released", "forgotten") if dask_scheduler.running else ("released", "forgotten")
    return [key for key in keys if key not in tasks or tasks[key].state in waiting]

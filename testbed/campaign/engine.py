"""The one engine that runs the cases of a sweep or campaign: Dask distributed.

`Engine()` starts a local cluster inside the command, one single-threaded worker process per
core (or `workers`); `Engine(scheduler="tcp://HOST:PORT")` submits to a hand-started cluster
(docs/campaigns.md, "Several machines"). Starting, reaching and closing a cluster within bounds,
whatever signal comes: testbed.campaign.cluster.

`results(fn, tasks)` yields (args, fn(*args)) as each case finishes, or (args, CaseLost) for a
case whose worker died running it twice or that ran past its timeout twice. The command places
each task itself, bound to one worker, DEPTH per worker thread. Blame for a worker's death goes
only to the oldest task the scheduler's record says was processing on that worker: the others
go back in the queue uncounted. (When tasks could move to another worker, one out on a worker
that had just died could die with a second worker and be blamed: 1 suite run in 3.) A task
stranded on a worker that is gone ('no-worker') is handed out again after STALL_S; one the
scheduler saw die (an external scheduler's own retries) counts as a death. A task out past
timeout_s(args) is given up: on the local cluster its worker process is ended (its nanny starts
another), on an external one that thread is given nothing more. Cases no worker can take become
CaseLost rather than wait forever. Ctrl-C cancels the cases out; leaving the `with` block closes
the local cluster.
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
                    # strictly on that worker: a task the scheduler moved elsewhere (its worker
                    # died before it started) could die with a worker it was not placed on and be
                    # blamed there; stranded instead, it is handed out again (hand_back_stranded)
                    future = self.client.submit(fn, *args, key=key, pure=False, workers=[address],
                                                allow_other_workers=False)
                    out[future] = (args, address, time.monotonic())
                    attempt.setdefault(name(args), time.monotonic())
                    queue.append(future)
                    finished.add(future)

        def hand_back_stranded() -> Iterator[tuple[tuple, CaseLost]]:
            """Tasks out for longer than STALL_S that the scheduler cannot run go back in the
            queue: a new key, placed on a worker that is there. One that was running when its
            worker died (an external scheduler retries such a task itself, on the worker it is
            bound to, which is gone) counts as a death: handed out RETRIES times, then a CaseLost."""
            old = [f for f, (_, _, handed) in out.items() if time.monotonic() - handed > STALL_S]
            if not old:
                return
            try:
                stranded = dict(self.client.run_on_scheduler(_stranded, [f.key for f in old]))
            except Exception:  # noqa: BLE001  (a scheduler that runs no code of ours: wait on)
                return
            for future in [f for f in old if f.key in stranded]:
                args, address, _ = out.pop(future)
                blame.pop(future, None)
                if future in queues.get(address, ()):
                    queues[address].remove(future)
                self.client.cancel([future])
                if stranded[future.key]:
                    deaths[name(args)] = deaths.get(name(args), 0) + 1
                    if deaths[name(args)] > RETRIES:
                        yield args, CaseLost(f"the worker process died running it, {deaths[name(args)]} times")
                        continue
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
                        yield from hand_back_stranded()
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
                died_on = _died_on(outcome[1]) if failed and isinstance(outcome[1], KilledWorker) else None
                if died_on == address and future not in blame:
                    # the first of a dead worker's tasks to be reported: the oldest out on it then
                    # is the one that killed it, whatever order the others are reported in
                    dead = queues.pop(address, [])
                    blame.update({f: i == 0 for i, f in enumerate(dead)})
                # only on the worker it was placed on and processing on (the scheduler's record),
                # and not one this command killed
                culprit = blame.pop(future, False) and died_on == address and address not in ended
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


def _died_on(error) -> str | None:
    """The address of the worker a KilledWorker's task was processing on when that worker died
    (the scheduler's own record), or None if the error does not say."""
    return getattr(getattr(error, "last_worker", None), "address", None)


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


def _stranded(keys: list, dask_scheduler=None) -> list[tuple[str, bool]]:
    """Of `keys`, those the scheduler cannot run (run on the scheduler), each with whether a worker
    died while running it: unknown to it, or in 'no-worker', waiting for a worker that is no longer
    there, while another one runs. (With no worker running, as while restarted ones start, a task
    handed out again would wait the same.)"""
    tasks = dask_scheduler.tasks
    waiting = ("no-worker", "released", "forgotten") if dask_scheduler.running else ("released", "forgotten")
    return [(key, key in tasks and tasks[key].suspicious > 0) for key in keys
            if key not in tasks or tasks[key].state in waiting]

"""The command's own book of the cases out on a Dask cluster (testbed.campaign.engine's
`results`): which task is on which worker, which worker died running what, which task ran past
its timeout or is stranded, and so which cases are retried and which become `CaseLost`.

Each task is bound to one worker, DEPTH per worker thread. A worker's death is blamed only on
the oldest task the scheduler's record says was processing on it (KilledWorker.last_worker);
the others go back in the queue uncounted. A task stranded on a worker that is gone
('no-worker') is handed out again after STALL_S; one the scheduler saw die (an external
scheduler's own retries) counts as a death. A task out past its timeout is given up: on the
local cluster its worker process is ended (its nanny starts another), on an external one that
thread is given nothing more. Cases no worker can take become CaseLost rather than wait forever.
A task that `split` divides (a batch of cases) is not retried after a death or an overrun: its
parts go first in the queue instead, each with its own retries and bound.
"""

from __future__ import annotations

import collections
import os
import time
import uuid
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator

RETRIES = 1  # a case whose worker died, or that ran past its timeout, runs once more
# No task has finished for this long: ask the scheduler whether any task out is stranded
# (placed on a worker that died meanwhile, it waits in 'no-worker' for that worker forever).
STALL_S = 2.0
POLL_S = 0.05
DEPTH = 1  # tasks out per worker thread: the one running


@dataclass(frozen=True)
class CaseLost:
    """The outcome of a task that gave no result: its worker process died running it twice, or
    it ran past its timeout twice, or no worker could take it."""

    reason: str


class CaseDispatch:
    """fn(*args) for every argument tuple of `tasks` on `client`'s cluster (`local`: one this
    command started, whose workers it may end); `name(args)` names a case uniquely,
    `timeout_s(args)` bounds its try (None: no bound); `no_worker_s`: how long a cluster may have
    no worker before the cases left are lost; `split(args)`: the parts a task runs as after a
    death or an overrun ([]: it is retried itself). `outcomes()` yields (args, result or CaseLost)."""

    def __init__(self, client, local: bool, fn: Callable, tasks: Iterable[tuple], name: Callable[[tuple], str],
                 timeout_s: Callable[[tuple], float | None], no_worker_s: float,
                 split: Callable[[tuple], list[tuple]] = lambda args: []):
        from distributed import as_completed

        self.client, self.local, self.fn, self.name, self.timeout_s = client, local, fn, name, timeout_s
        self.split = split
        self.no_worker_s = no_worker_s
        self.batch = uuid.uuid4().hex[:8]  # keys stay unique on a scheduler shared by several campaigns
        self.pending = collections.deque(tasks)  # a case handed out again goes first
        self.deaths: dict[str, int] = {}    # name -> how often a worker died running it
        self.overruns: dict[str, int] = {}  # name -> how often it ran past its timeout
        self.stuck: collections.Counter = collections.Counter()  # external worker -> threads held by a task given up
        self.ended: set[str] = set()        # local workers this command ended (the scheduler may list them a while)
        self.attempt: dict[str, float] = {}  # name -> when its current try was first handed out (kept when stranded)
        self.out: dict = {}                 # future -> (args, worker address, when handed out [monotonic s])
        self.queues: dict[str, list] = {}   # worker address -> its futures, oldest first
        self.blame: dict = {}               # future out on a worker that died -> whether it was the oldest
        self.finished = as_completed([], with_results=True, raise_errors=False)
        self.last_finish = time.monotonic()

    def outcomes(self) -> Iterator[tuple[tuple, Any]]:
        try:
            while self.pending or self.out:
                self._hand_out()
                if not self.out:  # every worker died and none is back yet, or every thread is held
                    yield from self._lose_the_rest(self._why_none_can_run())
                    time.sleep(0.1)
                elif not self.finished.has_ready():  # a bounded wait: a task can be stranded
                    _wait_a_little(self.finished)
                    yield from self._give_up_overdue()
                    if time.monotonic() - self.last_finish > STALL_S:
                        yield from self._hand_back_stranded()
                        self.last_finish = time.monotonic()
                else:
                    yield from self._take(*next(self.finished))
        finally:
            if self.out:
                self.client.cancel(list(self.out))

    def _hand_out(self) -> None:
        for address, worker in self.client.scheduler_info()["workers"].items():
            if address in self.ended:
                continue
            queue = self.queues.setdefault(address, [])
            while self.pending and len(queue) + self.stuck[address] < DEPTH * worker["nthreads"]:
                args = self.pending.popleft()
                key = f"{self.name(args)}-{self.batch}-{uuid.uuid4().hex[:8]}"  # a new key for each try
                # strictly on that worker: a task the scheduler moved elsewhere (its worker died
                # before it started) could die with a worker it was not placed on and be blamed
                # there (1 suite run in 3); stranded instead, it is handed out again
                future = self.client.submit(self.fn, *args, key=key, pure=False, workers=[address],
                                            allow_other_workers=False)
                self.out[future] = (args, address, time.monotonic())
                self.attempt.setdefault(self.name(args), time.monotonic())
                queue.append(future)
                self.finished.add(future)

    def _forget(self, future) -> tuple[tuple, str]:
        """(args, address) of a task out, no longer out: off its worker's queue, cancelled."""
        args, address, _ = self.out.pop(future)
        self.blame.pop(future, None)
        if future in self.queues.get(address, ()):
            self.queues[address].remove(future)
        self.client.cancel([future])
        return args, address

    def _died(self, args) -> Iterator[tuple[tuple, CaseLost]]:
        """A worker died running this case: handed out again RETRIES times, then a CaseLost (a
        task `split` divides: its parts, uncounted)."""
        if self._divided(args):
            return
        count = self.deaths[self.name(args)] = self.deaths.get(self.name(args), 0) + 1
        if count > RETRIES:
            yield args, CaseLost(f"the worker process died running it, {count} times")
        else:
            self.pending.appendleft(args)

    def _divided(self, args) -> bool:
        """Whether `split` divides the task: then its parts go first in the queue."""
        parts = self.split(args)
        self.pending.extendleft(reversed(parts))
        return bool(parts)

    def _take(self, future, outcome) -> Iterator[tuple[tuple, Any]]:
        """A task that finished: its result, or, for one its worker's death ended, a retry or a
        CaseLost if it was the one that killed the worker, else a retry uncounted."""
        from distributed import KilledWorker

        if future not in self.out:  # one handed out again (stranded): its cancellation
            return
        self.last_finish = time.monotonic()
        args, address, _ = self.out.pop(future)
        self.attempt.pop(self.name(args), None)  # its try is over: done, or handed out again as a new one
        failed = future.status == "error"
        future.release()
        if isinstance(outcome, BaseException):  # cancelled: the cluster went away
            raise outcome
        if failed and not isinstance(outcome[1], KilledWorker):  # outcome is (type, exception, traceback)
            raise outcome[1]
        died_on = _died_on(outcome[1]) if failed else None
        if died_on == address and future not in self.blame:
            # the first of a dead worker's tasks to be reported: the oldest out on it then is
            # the one that killed it, whatever order the others are reported in
            self.blame.update({f: i == 0 for i, f in enumerate(self.queues.pop(address, []))})
        # only where it was placed and processing (the scheduler's record), and not on a worker
        # this command ended
        culprit = self.blame.pop(future, False) and died_on == address and address not in self.ended
        if future in self.queues.get(address, ()):
            self.queues[address].remove(future)
        if not failed:
            yield args, outcome
        elif culprit:
            yield from self._died(args)
        else:  # one that waited behind the culprit is not to blame
            self.pending.appendleft(args)

    def _hand_back_stranded(self) -> Iterator[tuple[tuple, CaseLost]]:
        """Tasks out for longer than STALL_S that the scheduler cannot run go back in the queue:
        a new key, placed on a worker that is there. One that was running when its worker died
        (an external scheduler retries it itself, on the worker it is bound to, which is gone)
        counts as a death."""
        old = [f for f, (_, _, handed) in self.out.items() if time.monotonic() - handed > STALL_S]
        if not old:
            return
        try:
            stranded = dict(self.client.run_on_scheduler(_stranded, [f.key for f in old]))
        except Exception:  # noqa: BLE001  (a scheduler that runs no code of ours: wait on)
            return
        for future in [f for f in old if f.key in stranded]:
            args, _ = self._forget(future)
            if stranded[future.key]:
                yield from self._died(args)
            else:
                self.pending.appendleft(args)

    def _give_up_overdue(self) -> Iterator[tuple[tuple, CaseLost]]:
        """Tasks out for longer than their timeout: cancelled, and their worker process ended on
        the local cluster (its thread cannot be stopped otherwise; its nanny starts another), or
        left to its end on an external one, whose thread this command gives nothing more.
        Handed out again RETRIES times, then a CaseLost."""
        now = time.monotonic()
        for future, (args, address, handed) in list(self.out.items()):
            bound = self.timeout_s(args)
            if bound is None or now - self.attempt.get(self.name(args), handed) <= bound:
                continue
            self.attempt.pop(self.name(args), None)
            self._forget(future)
            if self.local:
                self.queues.pop(address, None)
                self.ended.add(address)
                self.client.run(_end_worker_process, workers=[address], wait=False)
            else:
                self.stuck[address] += 1
            if self._divided(args):
                continue
            count = self.overruns[self.name(args)] = self.overruns.get(self.name(args), 0) + 1
            if count <= RETRIES:
                self.pending.appendleft(args)
            else:
                yield args, CaseLost(f"ran longer than the case timeout of {bound:g} s, {_times(count)}")

    def _why_none_can_run(self) -> str | None:
        """Why no pending task can run, if none can: every worker thread held by a task given up
        (on an external cluster), or no worker at all for longer than no_worker_s."""
        info = self.client.scheduler_info()["workers"]
        if info and all(self.stuck[a] >= w["nthreads"] for a, w in info.items()):
            return "not run: every worker thread is still running a case that ran past its timeout"
        if not info and time.monotonic() - self.last_finish > self.no_worker_s:
            return f"not run: the cluster had no worker for {self.no_worker_s:g} s"
        return None

    def _lose_the_rest(self, why: str | None) -> Iterator[tuple[tuple, CaseLost]]:
        while why and self.pending:
            args = self.pending.popleft()
            tried = (f"ran longer than the case timeout of {self.timeout_s(args):g} s, once; then "
                     if self.overruns.get(self.name(args)) else "")
            yield args, CaseLost(tried + why)


def _times(count: int) -> str:
    return {1: "once", 2: "twice"}.get(count, f"{count} times")


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

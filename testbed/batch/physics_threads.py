"""A batch's physics spread over threads: MuJoCo's mj_step releases the GIL, so the worlds' steps
of one control tick run side by side on idle cores (each world's MjData is its own: the result
is the same to the bit whatever the threads)."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

# the longest one thread's share of a control tick's physics may take [s]: a wait with a bound
TICK_BOUND_S = 600.0


def idle_cores() -> int:
    """The cores this process may run on (its affinity)."""
    return len(os.sched_getaffinity(0))


def _each(calls: list) -> None:
    for call in calls:
        call()


class PhysicsThreads:
    """Runs a tick's per-world physics calls on `threads` threads (1: on the calling thread, in order).
    A campaign's workers already fill the cores, so its batches keep one; a vector environment,
    alone in its process, takes the idle cores (`idle_cores`)."""

    def __init__(self, threads: int = 1):
        self.threads = max(1, int(threads))
        self._pool = ThreadPoolExecutor(self.threads, thread_name_prefix="physics") if self.threads > 1 else None

    def run(self, calls: list) -> None:
        """Every call of `calls`, each once; returns when all have, re-raising the first failure."""
        if self._pool is None or len(calls) < 2 * self.threads:
            _each(calls)
            return
        shares = [calls[i::self.threads] for i in range(self.threads)]
        futures = [self._pool.submit(_each, share) for share in shares[1:]]
        _each(shares[0])  # the calling thread takes a share too
        for future in futures:
            future.result(timeout=TICK_BOUND_S)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

"""Start a campaign's local Dask cluster, or reach an external one, and close it: each within a
bound, whatever signal comes (testbed.campaign.engine runs the cases on it).

- `start_local(workers)`: a local cluster of `workers` single-threaded worker processes, at most
  MAX_WORKERS_PER_CPU per core (`max_workers`). A worker that has not started within
  START_TIMEOUT_S (a machine too loaded, too many workers) is bad input naming --workers.
- `connect(address)`: a client of the scheduler at `address`, which must complete Dask's
  handshake within SCHEDULER_TIMEOUT_S (distributed's own connect waits for it forever on a
  port that accepts and never answers) and have a worker within SCHEDULER_TIMEOUT_S more.
- `close(client, cluster)`.

Ctrl-C and SIGTERM are held while a cluster starts or closes (testbed.interrupts.signals_held)
and take effect as soon as it is up or closed: distributed stopped half-way prints its own
tracebacks and leaves worker processes behind. The local workers start with SIGINT blocked (a
thread's signal mask passes to the threads and processes it starts): Ctrl-C on a terminal
reaches the whole process group, and would kill a worker still importing, with a traceback.
"""

from __future__ import annotations

import logging
import os
import signal

from testbed.errors import InputError, quoted
from testbed.interrupts import signals_held

SCHEDULER_TIMEOUT_S = 5.0  # the handshake of --scheduler, its client's connection, its first worker
START_TIMEOUT_S = 60.0     # a local worker process, from spawn to ready (imports under load: seconds)
MAX_WORKERS_PER_CPU = 4    # more processes than that only share the cores (and memory) thinner


def max_workers() -> int:
    """The most worker processes a local cluster may have on this machine."""
    return MAX_WORKERS_PER_CPU * (os.cpu_count() or 1)


def checked_workers(workers: int) -> int:
    """`workers` if a local cluster may have that many (1 ... max_workers()); InputError otherwise."""
    if not 1 <= workers <= max_workers():
        raise InputError("--workers", f"must be 1 ... {max_workers()} ({MAX_WORKERS_PER_CPU} per core "
                                      f"of this machine's {os.cpu_count() or 1}), got {quoted(workers)}")
    return workers


def _fork_server_ignoring_ctrl_c() -> None:
    """Start multiprocessing's fork server, from which the local workers are forked (config
    LOCAL_CONFIG), with SIGINT ignored: a process started so keeps it ignored, and so does every
    worker forked from it, from its first instruction (module doc). The command's own handler is
    away for the few milliseconds of one fork and exec; a Ctrl-C then is lost."""
    import multiprocessing.forkserver

    from distributed.utils import get_mp_context

    get_mp_context()  # distributed's preload of the fork server (it imports distributed once, not each worker)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        multiprocessing.forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)


def quiet_closed_comms() -> None:
    """Silence asyncio's "Future exception was never retrieved" for this process: a comm that an
    interrupt closed under distributed's own loop is reported so, with a traceback, long after the
    command said "interrupted" (seen after a Ctrl-C at 1.5 s into the start, once in a whole suite)."""
    logging.getLogger("asyncio").setLevel(logging.CRITICAL)


def start_local(workers: int):
    """(cluster, client) of a local cluster of `workers` processes (already `checked_workers`;
    dask's config as it is set: the caller's LOCAL_CONFIG, for the cluster's whole life)."""
    from distributed import Client, LocalCluster

    quiet_closed_comms()
    cluster = client = None
    try:
        with signals_held():  # a signal held meanwhile is raised at its end: the cluster is closed below
            try:
                _fork_server_ignoring_ctrl_c()
                # no dashboard; the scheduler's own HTTP endpoint on a free loopback port, not 8787
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.CRITICAL,
                                       death_timeout=START_TIMEOUT_S,
                                       scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})
            except Exception as exc:  # noqa: BLE001  (a worker that did not start; distributed closed the rest)
                raise InputError("--workers", f"the local cluster of {workers} worker processes did not "
                                              f"start ({type(exc).__name__}: {exc}); try fewer") from None
            client = Client(cluster)
    except BaseException:
        close(client, cluster)
        raise
    return cluster, client


def _handshake(address: str, seconds: float) -> None:
    """Return once a Dask server at `address` has completed the handshake, else raise (within `seconds`)."""
    import asyncio

    from distributed.comm import connect

    async def shake():
        comm = await connect(address, timeout=seconds)
        await comm.close()

    asyncio.run(asyncio.wait_for(shake(), seconds))


def connect(address: str):
    """A client of the scheduler at `address` with at least one worker; InputError otherwise."""
    from distributed import Client

    quiet_closed_comms()

    client = None
    try:
        with signals_held():  # a signal held meanwhile is raised at its end: the client is closed below
            try:
                _handshake(address, SCHEDULER_TIMEOUT_S)
                client = Client(address, timeout=SCHEDULER_TIMEOUT_S)
            except Exception as exc:  # noqa: BLE001  (refused, timed out, or not a Dask scheduler at all)
                why = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
                raise InputError("--scheduler", f"no Dask scheduler answers at {address} within "
                                                f"{SCHEDULER_TIMEOUT_S:g} s ({why})") from None
            try:
                client.wait_for_workers(1, timeout=SCHEDULER_TIMEOUT_S)
            except Exception:  # noqa: BLE001
                raise InputError("--scheduler", f"the Dask scheduler at {address} has no worker "
                                                f"(none joined within {SCHEDULER_TIMEOUT_S:g} s)") from None
    except BaseException:
        close(client, None)
        raise
    return client


def close(client, cluster) -> None:
    """Close the client, then the local cluster (stopping its workers), signals held meanwhile."""
    with signals_held():
        for part in (client, cluster):
            if part is not None:
                try:
                    part.close()
                except Exception:  # noqa: BLE001  (closing after a failure: best effort)
                    pass

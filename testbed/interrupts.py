"""Ctrl-C and SIGTERM as exceptions that always reach the command line's exit (130, 143).

Python runs a signal handler between two bytecodes of the main thread, wherever it is. When
that is inside a finalizer (`__del__`: Rerun's RecordingStream has one, and every `log` call
creates and drops a temporary stream), an exception the handler raised would be printed as
"Exception ignored in ..." with a traceback and dropped, and the run would go on as if no
signal had come. So the handlers here look at where they run: inside a finalizer they deliver
the signal again a millisecond later (`_thread.interrupt_main`), by when the finalizer is over.
"""

from __future__ import annotations

import _thread
import contextlib
import functools
import signal
import threading
from typing import Callable

REDELIVERY_DELAY_S = 1e-3  # finalizers that run while a signal is handled take microseconds


class Terminated(BaseException):
    """SIGTERM (or another signal whose default is to end the process: OTHER_ENDING_SIGNALS),
    turned into an exception (like KeyboardInterrupt, not an Exception that a stage's error
    handling would catch) so that a trace being written is removed on the way out; the command
    then exits 128 + `signum`."""

    def __init__(self, signum: int = signal.SIGTERM):
        super().__init__(signum)
        self.signum = signum


# Signals whose default action ends the process with no clean-up (a plug-in's signal.alarm, a
# terminal hang-up): handled as SIGTERM is, where nothing else handles them (pytest-timeout's
# SIGALRM handler, say, stays).
OTHER_ENDING_SIGNALS = tuple(getattr(signal, name) for name in (
    "SIGHUP", "SIGALRM", "SIGUSR1", "SIGUSR2", "SIGQUIT", "SIGXCPU", "SIGXFSZ", "SIGVTALRM", "SIGPROF",
    "SIGPWR", "SIGSTKFLT") if hasattr(signal, name))  # SIGXCPU: what `ulimit -t` sends


def from_a_signal(exc: BaseException) -> bool:
    """Whether `exc` may be Ctrl-C or SIGTERM arriving: KeyboardInterrupt or `Terminated` in
    the main thread, where Python runs signal handlers. It ends the command (130, 143); raised
    in another thread (a campaign worker's) it is the raising code's own failure."""
    return isinstance(exc, (KeyboardInterrupt, Terminated)) and threading.current_thread() is threading.main_thread()


def inside_finalizer(frame) -> bool:
    """Whether `frame` or one of its callers is a `__del__`, where an exception is dropped."""
    while frame is not None:
        if frame.f_code.co_name == "__del__":
            return True
        frame = frame.f_back
    return False


def _raising(exception: Callable[[], BaseException], active: threading.Event):
    """A handler that raises `exception()`, or inside a finalizer delivers its signal again later,
    while `active` is set (once the block has ended, a late repeat would land outside it)."""
    def redeliver(signum):
        if active.is_set():
            _thread.interrupt_main(signum)

    def handle(signum, frame):
        if inside_finalizer(frame):
            later = threading.Timer(REDELIVERY_DELAY_S, redeliver, (signum,))
            later.daemon = True
            later.start()
            return
        raise exception()
    return handle


@contextlib.contextmanager
def signals_as_exceptions():
    """Within the block (in the main thread; elsewhere it does nothing): SIGINT raises
    KeyboardInterrupt and SIGTERM raises `Terminated`, both outside any finalizer, and so does
    each of OTHER_ENDING_SIGNALS that nothing handles; a signal the process was started ignoring
    stays ignored."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    active = threading.Event()
    active.set()
    previous = {signum: signal.signal(signum, _raising(exception, active))
                for signum, exception in ((signal.SIGINT, KeyboardInterrupt), (signal.SIGTERM, Terminated))
                if signal.getsignal(signum) != signal.SIG_IGN}  # `nohup`, a background job: still ignored
    previous |= {signum: signal.signal(signum, _raising(functools.partial(Terminated, signum), active))
                 for signum in OTHER_ENDING_SIGNALS if signal.getsignal(signum) == signal.SIG_DFL}
    try:
        yield
    finally:
        active.clear()
        for signum, handler in previous.items():
            signal.signal(signum, handler)


@contextlib.contextmanager
def signals_held():
    """Within the block (in the main thread; elsewhere it does nothing): SIGINT, SIGTERM and each
    of OTHER_ENDING_SIGNALS that has a Python handler are noted, not handled; at its end the
    handlers are back and the first signal noted is raised again, so it takes effect there
    (KeyboardInterrupt, `Terminated`). For code that must not stop half-way for a bounded time:
    Dask starting or closing a cluster, a temporary file made and its name kept (the name is
    what the way out removes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[int] = []
    previous = {signum: signal.signal(signum, lambda signum, frame: noted.append(signum))
                for signum in (signal.SIGINT, signal.SIGTERM) + OTHER_ENDING_SIGNALS
                if callable(signal.getsignal(signum))}  # SIG_IGN stays ignored, SIG_DFL ends at once
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if noted:
            signal.raise_signal(noted[0])

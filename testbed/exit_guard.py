"""`os._exit` called by a plug-in's code raises instead of ending the process.

`os._exit(0)` from a stage would end the command at once with status 0, as if the run had
passed, and a campaign worker with it. Within `os_exit_raises()` it raises `ExitCalled` in the
thread that entered the block, so that the stage's failure is reported like any other
(testbed.pipeline). Other threads, and a child forked meanwhile (multiprocessing ends its
children with os._exit), still exit for real. A C library's exit() or a kill cannot be caught.
"""

from __future__ import annotations

import contextlib
import os
import threading

_real_exit = os._exit
_guarded: set[int] = set()  # idents of the threads inside an `os_exit_raises` block
_lock = threading.Lock()


class ExitCalled(SystemExit):
    """os._exit(code) called inside `os_exit_raises()`; left uncaught, Python exits with `code`."""


def _exit(code: int) -> None:
    if threading.get_ident() in _guarded:
        raise ExitCalled(code)
    _real_exit(code)


def _after_fork_in_child() -> None:
    """A forked child is not running the parent's stage: its os._exit exits."""
    global _lock
    _lock = threading.Lock()  # another thread of the parent may have held it
    _guarded.clear()
    os._exit = _real_exit


os.register_at_fork(after_in_child=_after_fork_in_child)


@contextlib.contextmanager
def os_exit_raises():
    """Within the block, os._exit called in this thread raises `ExitCalled`; os._exit is the
    original again once no thread is inside such a block (nested blocks are one)."""
    ident = threading.get_ident()
    with _lock:
        nested = ident in _guarded  # the outer block restores
        _guarded.add(ident)
        os._exit = _exit
    try:
        yield
    finally:
        if not nested:
            with _lock:
                _guarded.discard(ident)
                if not _guarded:
                    os._exit = _real_exit

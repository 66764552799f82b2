"""What a plug-in's code may not do to the command's process: `os._exit`, `os.fork`, and
changing how SIGINT or SIGTERM are handled each raise instead.

`os._exit(0)` from a stage would end the command at once with status 0, as if the run had
passed, and a campaign worker with it; a forked process would run the stage on, unseen, and
hold the command's files; a stage that ignores SIGINT takes the user's Ctrl-C away. Within
`os_exit_raises()` each raises in the thread that entered the block (`ExitCalled`, or
`PluginRefused`), so that the stage's failure is reported like any other (testbed.pipeline).
Other threads, and a child forked meanwhile (multiprocessing ends its children with os._exit),
are not held. A C library's exit() or a kill cannot be caught.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

_real_exit, _real_fork, _real_signal = os._exit, os.fork, signal.signal
_guarded: set[int] = set()  # idents of the threads inside an `os_exit_raises` block
_lock = threading.Lock()
COMMAND_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class ExitCalled(SystemExit):
    """os._exit(code) called inside `os_exit_raises()`; left uncaught, Python exits with `code`."""


class PluginRefused(RuntimeError):
    """Plug-in code inside `os_exit_raises()` did what it may not: fork, or take a signal."""


def _exit(code: int) -> None:
    if threading.get_ident() in _guarded:
        raise ExitCalled(code)
    _real_exit(code)


# Code that is not a plug-in's: the testbed's own, Python's and the installed libraries'
# (pytest-timeout's alarm, IPython's Ctrl-C handler).
_LIBRARY_ROOTS = tuple({os.path.dirname(os.path.abspath(__file__)) + os.sep, sys.prefix + os.sep,
                        sys.base_prefix + os.sep, sys.exec_prefix + os.sep})


def _plugin_code(frame) -> bool:
    """Whether `frame` (the caller of a guarded function) runs code outside the testbed, Python
    and the installed libraries: a plug-in's (or a user's own stage given from Python)."""
    file = frame.f_code.co_filename
    return not (file.startswith(_LIBRARY_ROOTS) or file.startswith("<"))


def _fork() -> int:
    if threading.get_ident() in _guarded and _plugin_code(sys._getframe(1)):
        raise PluginRefused("os.fork() in plug-in code: the run's process may not be forked")
    return _real_fork()


def _signal(signum, handler):
    if threading.get_ident() in _guarded and signum in COMMAND_SIGNALS and _plugin_code(sys._getframe(1)):
        raise PluginRefused(f"signal.signal({signal.Signals(signum).name}, ...) in plug-in code: "
                            "SIGINT and SIGTERM end the command (130, 143)")
    return _real_signal(signum, handler)


def _install(exit_, fork, set_signal) -> None:
    """The process's os._exit, os.fork and signal.signal from now on."""
    os._exit, os.fork, signal.signal = exit_, fork, set_signal


def _after_fork_in_child() -> None:
    """A forked child is not running the parent's stage: its os._exit exits."""
    global _lock
    _lock = threading.Lock()  # another thread of the parent may have held it
    _guarded.clear()
    _install(_real_exit, _real_fork, _real_signal)


os.register_at_fork(after_in_child=_after_fork_in_child)


@contextlib.contextmanager
def os_exit_raises():
    """Within the block, os._exit called in this thread raises `ExitCalled`, and os.fork and
    signal.signal of SIGINT or SIGTERM raise `PluginRefused`; each is the original again once no
    thread is inside such a block (nested blocks are one)."""
    ident = threading.get_ident()
    with _lock:
        nested = ident in _guarded  # the outer block restores
        _guarded.add(ident)
        _install(_exit, _fork, _signal)
    try:
        yield
    finally:
        if not nested:
            with _lock:
                _guarded.discard(ident)
                if not _guarded:
                    _install(_real_exit, _real_fork, _real_signal)

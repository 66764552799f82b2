"""Command line: `testbed run | check | list | inspect | sweep | init | describe` (see README);
`entry` is the process's entry point (`[project.scripts] testbed = "testbed.cli:entry"`,
`python -m testbed`), `main` the command itself (tests call it in their own process)."""

import os
import signal
import sys
import threading
import time

# Once the command is over, the process ends within this long, whatever plug-in code left
# running (a thread that never ends, an atexit handler that sleeps).
EXIT_BOUND_S = 10.0


def main(argv: list[str] | None = None) -> int:
    """The command line (testbed.cli.dispatch.main). Its modules, and MuJoCo, SciPy, Rerun and
    Dask behind them, are imported here: a Ctrl-C meanwhile is exit 130 with one line, as later."""
    try:
        from testbed.cli.dispatch import main as dispatch
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    try:
        return dispatch(argv)
    except KeyboardInterrupt:  # a Ctrl-C delivered again while the command was already answering one
        return 130


def entry() -> None:
    """Run the command and end the process with its status: Python's own shutdown (joining
    threads, atexit handlers) may take EXIT_BOUND_S at most, and an error it reports is one line."""
    code = main()
    # The command is over and its status known: a signal from now on (a late repeat of one the
    # command answered, or one sent while plug-in code delays the exit) ends the process at once
    # with that status, never with a traceback or as killed by the signal.
    for signum in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(signum) != signal.SIG_IGN:
            signal.signal(signum, lambda *_: _exit_now(code))
    sys.unraisablehook = _one_line
    threading.Thread(target=_end_after, args=(code, EXIT_BOUND_S), daemon=True).start()
    sys.exit(code)


def _exit_now(code: int) -> None:
    """End the process with `code` at once, after writing out what the command printed."""
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # a closed or broken stream: nothing more to keep
            pass
    os._exit(code)


def _end_after(code: int, seconds: float) -> None:
    time.sleep(seconds)
    stderr = sys.__stderr__
    if stderr is not None:
        print(f"note: plug-in code kept the process from ending; ended it {seconds:g} s after the command",
              file=stderr, flush=True)
    os._exit(code)


def _one_line(unraisable) -> None:
    """What Python reports and ignores at shutdown (an atexit handler that raised), in one line."""
    stderr = sys.__stderr__
    if stderr is not None:
        what = unraisable.err_msg or "Exception ignored"
        print(f"warning: {what}: {unraisable.exc_type.__name__}: {str(unraisable.exc_value)[:200]}",
              file=stderr, flush=True)


__all__ = ["entry", "main"]

"""With `--json` a command's stdout holds only its JSON document: while it works, whatever a
plug-in prints (Python's print, or a write to file descriptor 1 from C or a child process, a
campaign's worker processes too) goes to stderr."""

from __future__ import annotations

import contextlib
import os
import sys


def _fd_moved(source: int, target: int) -> int | None:
    """Point file descriptor `source` at `target`'s file; returns a copy of what it was, or None
    when either is closed (then only Python's writes are redirected)."""
    try:
        saved = os.dup(source)
    except OSError:
        return None
    try:
        os.dup2(target, source)
    except OSError:
        os.close(saved)
        return None
    return saved


@contextlib.contextmanager
def stdout_to_stderr():
    """Within the block, stdout (sys.stdout and file descriptor 1) writes to stderr; stdout is
    flushed before and after, so nothing written before or after changes place."""
    original = sys.stdout
    if original is not None:
        original.flush()
    saved = _fd_moved(1, 2)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        try:
            if original is not None:
                original.flush()  # what code holding the original object wrote: to stderr still
        finally:
            if saved is not None:
                os.dup2(saved, 1)
                os.close(saved)


def reserved_for_json(json: bool):
    """`stdout_to_stderr()` for a command that prints JSON (`json`), else a block that changes nothing."""
    return stdout_to_stderr() if json else contextlib.nullcontext()

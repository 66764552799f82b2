"""The one progress bar of the command line (tqdm): on a terminal only, shown once a job has
taken more than 2 s, written to stderr so that stdout stays the result; and the line that says
a run is being built (`building_notice`), shown once building has taken BUILD_NOTICE_S."""

from __future__ import annotations

import contextlib
import sys
import threading
import time

from tqdm import tqdm


def progress_bar(label: str, total: float, unit: str) -> tqdm:
    """A bar for `total` units of work, hidden when stderr is not a terminal."""
    return tqdm(total=total, desc=label, unit=unit, delay=2.0, file=sys.stderr, leave=False,
                dynamic_ncols=True, disable=not sys.stderr.isatty(),
                bar_format="{desc} {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} {unit} [{elapsed}<{remaining}{postfix}]")


def advance_to(bar: tqdm, done: float, **postfix) -> None:
    """Move `bar` to `done` units (and show `postfix`, e.g. a count of failed cases)."""
    if postfix:
        bar.set_postfix(postfix, refresh=False)
    bar.update(done - bar.n)


BUILD_NOTICE_S = 1.0


@contextlib.contextmanager
def building_notice(label: str, show: bool, after_s: float = BUILD_NOTICE_S, stream=None):
    """While the block builds a run (model, pipeline, reference, planning), a line on `stream`
    (stderr) once it has taken `after_s`: `building LABEL ...`, completed with its time when the
    block ends. Nothing when `show` is False (not a terminal, or --json) or the block is quick."""
    stream = stream or sys.stderr
    if not show:
        yield
        return
    start, lock, state = time.perf_counter(), threading.Lock(), {"building": True, "shown": False}

    def notice():
        with lock:
            if state["building"]:
                stream.write(f"building {label} (model, pipeline, reference) ...")
                stream.flush()
                state["shown"] = True

    timer = threading.Timer(after_s, notice)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        with lock:
            state["building"] = False
            if state["shown"]:
                stream.write(f" {time.perf_counter() - start:.1f} s\n")
                stream.flush()

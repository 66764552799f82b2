"""A Rerun recording's file sink whose failure to write (a full disk) ends in an error naming the
file (testbed.errors.WriteFailed), never in a hang.

Rerun 0.41 writes a file sink on its own thread; when a write fails that thread logs the OS error
and stops. A flush then fails ("File-writer thread shut down prematurely"), or, when the flush
was queued as the thread stopped, waits forever, and so do `disconnect` and the stream's drop
(at exit too). So a flush here waits in steps of FLUSH_STEP_S, asks the file system after each
step whether a write in the file's folder fails now (the reason Rerun's log line would give)
or whether the file stopped growing, and a stream whose writer stopped is abandoned: never disconnected or dropped.
"""

from __future__ import annotations

import ctypes
import os
import time
from pathlib import Path

from testbed.recording.rerun_sdk import rr

from testbed.recording.atomic_file import partial_beside
from testbed.recording.rrd_frames import whole_frames_end
from testbed.errors import WriteFailed
from testbed.interrupts import signals_held

FLUSH_STEP_S = 0.5
FLUSH_TIMEOUT_S = 120.0  # a flush of one chunk takes milliseconds; this is a disk that stopped answering
# a flush this long without the file growing: the writer stopped on a write that failed while the
# folder has room again (another writer's file removed meanwhile)
STALL_S = 10.0
PROBE_BYTES = 64 * 1024  # more than fits once a write failed: Rust's write_all fills the disk first


def write_refusal(folder: Path) -> str | None:
    """Why a write of PROBE_BYTES in `folder` fails now ("No space left on device"); None if it succeeds."""
    with signals_held():  # a signal in between would leave the probe behind
        try:
            handle, probe = partial_beside(Path(folder) / "write-probe")
        except OSError as exc:
            return exc.strerror or str(exc)
        try:
            os.write(handle, bytes(PROBE_BYTES))
        except OSError as exc:
            return exc.strerror or str(exc)
        finally:
            os.close(handle)
            os.unlink(probe)
    return None


class FileStream:
    """`rec` streaming to `partial` (the file being written for `path`, which messages name), with
    the calls a trace writer makes (log, send_columns, send_blueprint, flush): `flush` within
    FLUSH_TIMEOUT_S or WriteFailed; `close` or `close_after` an error end it."""

    def __init__(self, rec, partial: str, path: Path):
        self.rec, self.partial, self.path = rec, partial, Path(path)
        self.pending = False  # a flush was begun and did not end: the writer may be stuck in it

    @classmethod
    def opened(cls, rec, partial: str, path: Path, footer: bool) -> "FileStream":
        """`rec` given a file sink on `partial` (Rerun writes the file's header at once: a full
        disk refuses it here, WriteFailed)."""
        try:
            rec.set_sinks(rr.FileSink(partial, write_footer=footer))
        except RuntimeError as exc:  # "Failed to encode LogMsg: Failed to write: ..."
            raise WriteFailed(path, write_refusal(Path(path).parent) or f"Rerun's file sink: {exc}") from None
        return cls(rec, partial, path)

    def log(self, *args, **kwargs):
        self.rec.log(*args, **kwargs)

    def send_columns(self, *args, **kwargs):
        self.rec.send_columns(*args, **kwargs)

    def send_blueprint(self, *args, **kwargs):
        self.rec.send_blueprint(*args, **kwargs)

    def flush(self) -> None:
        self.pending = True
        deadline = time.monotonic() + FLUSH_TIMEOUT_S
        size, still_since = self._size(), time.monotonic()
        while True:
            try:
                self.rec.flush(timeout_sec=FLUSH_STEP_S)
                break
            except RuntimeError as exc:  # the writer stopped, or the step ran out
                refusal = write_refusal(self.path.parent)
                if refusal is not None:
                    raise WriteFailed(self.path, refusal) from None
                if "timed out" not in str(exc):
                    raise WriteFailed(self.path, f"Rerun's file writer stopped: {exc}") from None
                now = time.monotonic()
                if self._size() != size:
                    size, still_since = self._size(), now
                elif now - still_since > STALL_S:  # stopped by a write that failed where there is room now
                    raise WriteFailed(self.path, f"Rerun's file writer stopped writing it for {STALL_S:g} s") from None
                if now > deadline:
                    raise WriteFailed(self.path, f"Rerun's file writer took more than {FLUSH_TIMEOUT_S:g} s") from None
        self.pending = False

    def _size(self) -> int:
        try:
            return os.stat(self.partial).st_size
        except OSError:
            return -1

    def close(self) -> None:
        """Every logged message flushed and the file ended (Rerun's footer if asked for). Rerun
        writes the end on its own thread and says nothing when that write fails: a file that does
        not end on a whole message is WriteFailed, not a finished trace."""
        self.flush()
        self.rec.disconnect()
        size = self._size()
        if whole_frames_end(Path(self.partial)) < size:
            raise WriteFailed(self.path, write_refusal(self.path.parent)
                              or f"Rerun's file writer left its last {size - whole_frames_end(Path(self.partial))} "
                                 f"bytes cut short")

    def close_after(self, error: BaseException) -> None:
        """End the stream as a block that raised `error` leaves it: abandoned when the writer may be
        stuck (a failed or unfinished flush), else disconnected."""
        if isinstance(error, WriteFailed) or self.pending:
            abandon(self.rec)
        else:
            self.rec.disconnect()


_abandoned: list = []


def abandon(rec) -> None:
    """Keep `rec` alive to the end of the process, never dropped (its drop, like Rerun's own
    flush of every stream at exit, would wait on a writer that never answers)."""
    _abandoned.append(rec)
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(rec))  # not even at interpreter shutdown
    rr.unregister_shutdown()

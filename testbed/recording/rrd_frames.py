"""Reading an `.rrd` whose writer died mid-message (SIGKILL, os._exit, a crash): Rerun refuses
the whole file for its last, cut message, so it is read up to the last whole one.

Rerun 0.41's framing: a 12-byte file header ("RRF2", version, options), then messages, each a
16-byte header (kind, payload length: little-endian u64) and its payload; kind 0 ends the stream
(a footer may follow).
"""

from __future__ import annotations

import os
import shutil
import struct
import tempfile
from pathlib import Path

FILE_HEADER_BYTES = 12
MESSAGE_HEADER = struct.Struct("<QQ")
END_OF_STREAM = 0


def whole_frames_end(path: Path) -> int:
    """The byte offset just after the last whole message of `path` (FILE_HEADER_BYTES when none is whole)."""
    size = os.path.getsize(path)
    end = FILE_HEADER_BYTES
    with open(path, "rb") as handle:
        while end + MESSAGE_HEADER.size <= size:
            handle.seek(end)
            kind, length = MESSAGE_HEADER.unpack(handle.read(MESSAGE_HEADER.size))
            if end + MESSAGE_HEADER.size + length > size:
                break
            end += MESSAGE_HEADER.size + length
            if kind == END_OF_STREAM:
                return size  # a stream that ended: nothing was cut
    return min(end, size)


def read_whole_frames(path: Path, read):
    """(`read(path)`, bytes cut off): `read` of the file itself, or when that fails on a file cut
    mid-message, of a temporary copy of its whole messages (the error stands if that fails too)."""
    try:
        return read(path), 0
    except Exception as exc:  # noqa: BLE001  (Rerun's decode error; a copy of the whole messages may read)
        end, size = whole_frames_end(path), os.path.getsize(path)
        if end >= size:
            raise
        refusal = exc
    with tempfile.TemporaryDirectory() as folder:
        copy = Path(folder) / "whole.rrd"
        with open(path, "rb") as source, open(copy, "wb") as target:
            shutil.copyfileobj(_first(source, end), target)
        try:
            return read(copy), size - end
        except Exception:  # noqa: BLE001  (no run in the whole messages either: the file's own error stands)
            raise refusal from None


class _first:
    """The first `count` bytes of a binary file, as a file to copy from."""

    def __init__(self, handle, count: int):
        self.handle, self.left = handle, count

    def read(self, n: int = -1) -> bytes:
        n = self.left if n < 0 else min(n, self.left)
        data = self.handle.read(n)
        self.left -= len(data)
        return data

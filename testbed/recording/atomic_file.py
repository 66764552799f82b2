"""Files that appear whole or not at all: written under a temporary name beside their path and
renamed onto it when complete (README "Exit status": nothing half-written is left as a result).

The temporary name is `.<name>.<random>.partial`, unique per writer, so two writers of one
path each leave a whole file; `publish` gives it the permissions `open()` would have given
(mkstemp makes it private) and renames it."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from testbed.errors import write_failed
from testbed.interrupts import signals_held


# bytes of the final name kept in the temporary one: with the dots, mkstemp's 8 random
# characters and ".partial" it stays far inside any file system's 255-byte name limit
NAME_KEPT = 100


def partial_beside(path: Path) -> tuple[int, str]:
    """(open descriptor, name) of a new unique temporary file in `path`'s folder, named
    `.<the first NAME_KEPT bytes of its name>.<random>.partial`."""
    kept = Path(path).name.encode()[:NAME_KEPT].decode(errors="ignore")  # never half a character
    return tempfile.mkstemp(dir=Path(path).parent, prefix=f".{kept}.", suffix=".partial")


def publish(partial: str, path: Path, overwrite: bool = True) -> None:
    """Rename the finished `partial` onto `path` with an ordinary file's permissions (0o666 less
    the umask); with `overwrite` False a file already at `path` is kept (FileExistsError): the
    partial is hard-linked there, which fails if the name is taken, then removed."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(partial, 0o666 & ~mask)
    if overwrite:
        os.replace(partial, path)
        return
    try:
        os.link(partial, path)
    finally:
        os.unlink(partial)


class atomic_file:
    """`with atomic_file(path) as handle:` a file written under a temporary name beside `path`,
    renamed onto it when the block ends normally and removed when it raises; an OSError while
    writing it (a full disk) becomes testbed.errors.WriteFailed naming `path`. `overwrite=False`:
    a file that is at `path` when the block ends stays, FileExistsError (see `publish`)."""

    def __init__(self, path: Path, binary: bool = False, overwrite: bool = True):
        self.path, self.binary, self.overwrite = Path(path), binary, overwrite

    def __enter__(self):
        self.partial = None
        try:
            with signals_held():  # a signal before the name is kept would leave the file behind
                fd, self.partial = partial_beside(self.path)
                self.handle = os.fdopen(fd, "wb" if self.binary else "w", **({} if self.binary else {"newline": ""}))
        except BaseException as exc:  # __exit__ is not called when __enter__ raises: remove what was made
            if self.partial is not None:
                Path(self.partial).unlink(missing_ok=True)
            if isinstance(exc, OSError):  # no room for even an empty file (no inodes left)
                raise write_failed(self.path, exc) from None
            raise  # the signal held above
        return self.handle

    def __exit__(self, kind, value, traceback):
        try:
            self.handle.close()  # may fail too: its last buffer is written now
            if kind is None:
                publish(self.partial, self.path, self.overwrite)
        except FileExistsError:  # not a write that failed: the name was taken meanwhile
            Path(self.partial).unlink(missing_ok=True)
            raise
        except OSError as exc:
            Path(self.partial).unlink(missing_ok=True)
            raise write_failed(self.path, value if isinstance(value, OSError) else exc) from None
        if kind is not None:
            Path(self.partial).unlink(missing_ok=True)
            if issubclass(kind, OSError):  # a write that failed (a full disk), named by the file
                raise write_failed(self.path, value) from None
        return False


def write_atomically(path: Path, text: str) -> None:
    """`text` into `path`, through a temporary file renamed onto it (never half a file)."""
    with atomic_file(path) as handle:
        handle.write(text)

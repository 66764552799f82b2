"""Where a trace is written: a scenario name made a file name, and an output path checked
before any run (a name the file system takes, a writable folder) while creating nothing."""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from testbed.errors import InputError, quoted
from testbed.interrupts import signals_held
from testbed.recording.atomic_file import partial_beside

NAME_MAX = 255  # bytes in one file or folder name (ext4 and most others)


def file_stem(name: str) -> str:
    """A scenario name made safe as a file name: no separators, no leading dots, no '..', at
    most 100 characters (file systems take 255 bytes, and a suffix and a temporary part follow)."""
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", name).lstrip(".")
    return stem.replace("..", "_")[:100] or "run"


def default_output(source: str, name: str, folder: str | Path = "runs", field: str = "--out") -> "CheckedPath":
    """The trace path of a run given no --out: `folder/<scenario file stem>.rrd` (`name`, the
    scenario's name, when it has no file), checked like `checked_output`. A trace there that
    records another scenario file is refused, never replaced: two files of one stem in different
    folders (or a copy named like its original) would otherwise overwrite each other's traces."""
    path = checked_output(Path(folder) / f"{file_stem(Path(source).stem if source else name)}.rrd", field)
    if source and path.path.is_file():
        from testbed.recording.trace_reader import recorded_source

        held = recorded_source(path.path)
        if held is not None and Path(held) != Path(source).resolve():
            raise InputError(field, f"{quoted(str(path.path))} holds the trace of another scenario file, "
                                    f"{quoted(held)}; give --out, or move that trace away")
    return path


@dataclass(frozen=True)
class CheckedPath:
    """A trace path `output_path` has checked (`checked_output`), handed down to a run
    (`testbed.run`) so that it is not checked again."""

    path: Path

    def __fspath__(self) -> str:
        return str(self.path)


def checked_output(out, field: str = "--out") -> CheckedPath:
    """`output_path(out, field)`, marked as checked."""
    return CheckedPath(output_path(out, field))


def output_path(out, field: str = "--out") -> Path:
    """Where a trace may be written, checked before any run and creating nothing: not a
    directory (a trailing separator means one) or a device, not under a file, its nearest
    existing folder writable, a name the file system takes. A symlink is written through (its
    target is replaced, the link stays)."""
    text = str(out)
    if not text:  # Path("") is the current folder
        raise InputError(field, "is empty; give a file name such as run.rrd")
    try:
        path = Path(text).expanduser()
        if text.endswith(("/", os.sep)) or path.is_dir():
            raise InputError(field, f"{quoted(text)} is a directory; give a file name such as run.rrd")
        if path.exists() and not path.is_file():
            raise InputError(field, f"{quoted(text)} is not a regular file")
        path = path.resolve(strict=False)
        check_creatable(path, field)
    except OSError as exc:
        raise InputError(field, f"cannot write {quoted(text)}: {exc.strerror}") from None
    except (RuntimeError, ValueError) as exc:  # a symlink loop, a NUL byte in the name
        raise InputError(field, f"cannot write {quoted(text)}: {exc}") from None
    return path


def check_creatable(path: Path, field: str) -> None:
    """`path` (absolute) can be created without creating anything now: every name fits the file
    system (NAME_MAX bytes, no NUL), its nearest existing folder is a folder and writable."""
    for part in path.parts[1:]:
        if len(part.encode()) > NAME_MAX or "\0" in part:
            raise InputError(field, f"{quoted(part)} is not a name the file system takes (at most {NAME_MAX} bytes)")
    existing = next(a for a in [path.parent, *path.parent.parents] if a.exists())
    if not existing.is_dir():
        raise InputError(field, f"{quoted(str(existing))} is a file, so {quoted(str(path))} cannot be created")
    # the one sure test: create (and remove) the kind of temporary file the trace is written to
    with signals_held():  # a signal in between would leave the probe behind
        handle, probe = partial_beside(existing / path.name)
        os.close(handle)
        os.unlink(probe)

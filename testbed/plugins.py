"""Where stages, systems, metrics and references come from: the package's own folders, installed
plug-in packages, and the Python files or modules a scenario names.

- Built-ins: every module of every folder of `testbed` but the shared machinery (`testbed.stages`,
  one folder per method, every package of `testbed.systems`: `discover()`), so a new stage
  file, method folder or system folder needs no edit to any shared file.
- Installed plug-ins: every entry point of the group `testbed.plugins` (a package declares
  `[project.entry-points."testbed.plugins"] name = "its_module"`), loaded by `discover()`.
- Scenario plug-ins: `plugins: [my_laws.py, mylab.controllers]` in a scenario file: a file
  path relative to the scenario file, or an importable module name (`load_plugins`).

A plug-in registers with the same decorators as the built-ins (`testbed.stage`,
`testbed.system`, `testbed.metric`, `testbed.reference`). It may not take a name that is
already registered: a plug-in that would shadow a built-in is refused; give it a namespaced
name such as "mylab.pd". A plug-in is code the user chose to run, with the user's rights.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.metadata
import importlib.util
import os
import pkgutil
import sys
import traceback
from pathlib import Path

from testbed import exit_guard
from testbed.errors import InputError, described
from testbed.interrupts import from_a_signal
from testbed.math.validation import existing_file
from testbed.registry import DuplicateName, restore, snapshot

# the folders that register no stage, system, metric or reference (testbed.gym registers Gymnasium
# environments, once imported); every other folder of testbed holds built-in plug-ins
SHARED_PACKAGES = ("testbed.math", "testbed.campaign", "testbed.recording", "testbed.cli", "testbed.scenario",
                   "testbed.stepping", "testbed.gym", "testbed.run_core", "testbed.batch")
ENTRY_POINT_GROUP = "testbed.plugins"

_discovered = False
_loaded: dict[str, object] = {}  # resolved file path or module name -> module


def discover() -> None:
    """Import the built-in plug-in folders once, then the installed plug-in packages."""
    global _discovered
    if _discovered:
        return
    for folder in pkgutil.iter_modules(importlib.import_module("testbed").__path__, "testbed."):
        if not folder.ispkg or folder.name in SHARED_PACKAGES:
            continue
        package = importlib.import_module(folder.name)
        for info in pkgutil.iter_modules(package.__path__, folder.name + "."):
            importlib.import_module(info.name)
    _discovered = True
    for entry in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        _load(f"entry point {entry.name} ({entry.value})", entry.value, entry.load, where=entry.value)


def load_plugins(entries: list[str], base: Path, field: str = "plugins") -> None:
    """Import a scenario's plug-ins: `base`-relative .py files or module names, each once per process."""
    discover()
    for i, entry in enumerate(entries):
        path = base / entry if entry.endswith(".py") else None
        if path is not None:
            if not existing_file(f"{field}[{i}]", path):
                raise InputError(f"{field}[{i}]", f"no such plug-in file: {path}")
            path = path.resolve()
            _load(f"{field}[{i}]", str(path), lambda p=path: _import_file(p), where=str(path))
        else:
            if not entry.replace(".", "").replace("_", "").isalnum() or importlib.util.find_spec(entry.split(".")[0]) is None:
                raise InputError(f"{field}[{i}]", f"no module named {entry!r} (a file needs the .py ending)")
            _load(f"{field}[{i}]", entry, lambda e=entry: importlib.import_module(e), where=entry)


def _load(field: str, key: str, do_import, where: str) -> None:
    """Run one plug-in import; on any failure undo what it registered and raise InputError
    naming the plug-in, and the file and line where it failed."""
    if key in _loaded:
        return
    saved = snapshot()
    cwd, streams = os.getcwd(), (sys.stdout, sys.stderr)
    try:
        with exit_guard.os_exit_raises():
            _loaded[key] = do_import()
    except DuplicateName as exc:
        restore(saved)
        raise InputError(field, f"{where}: {exc}: a plug-in may not shadow a built-in or another "
                                f"plug-in; give it a namespaced name (e.g. 'mylab.<name>')") from None
    except BaseException as exc:  # the plug-in's own code failed (sys.exit too): report where, not our traceback
        restore(saved)
        if from_a_signal(exc):
            raise
        raise InputError(field, f"{_failure_place(exc, where)}: {described(exc)}") from None
    finally:
        # what the import may have changed of the command's own process: the folder relative
        # paths are taken in, and where its output and errors go
        if os.getcwd() != cwd:
            os.chdir(cwd)
        if sys.stdout is None or sys.stderr is None:  # not a redirection another thread may have made meanwhile
            sys.stdout, sys.stderr = sys.stdout or streams[0], sys.stderr or streams[1]


def _failure_place(exc: BaseException, where: str) -> str:
    """file:line of the failure inside the plug-in (its last frame), else the plug-in's name."""
    if isinstance(exc, SyntaxError) and exc.filename:
        return f"{exc.filename}:{exc.lineno}"
    ours = {Path(__file__).resolve(), Path(exit_guard.__file__).resolve()}  # os._exit raises in exit_guard
    frames = [f for f in traceback.extract_tb(exc.__traceback__)
              if "importlib" not in f.filename and not f.filename.startswith("<frozen")
              and Path(f.filename).resolve() not in ours]
    return f"{frames[-1].filename}:{frames[-1].lineno}" if frames else where


def _imported_from(path: Path):
    """The module already imported from the file `path` (resolved), under any name, else None."""
    for module in list(sys.modules.values()):
        source = getattr(module, "__file__", None)
        if isinstance(source, str):
            try:
                if Path(source).resolve() == path:
                    return module
            except (OSError, RuntimeError, ValueError):
                continue
    return None


def _import_file(path: Path):
    """Import a plug-in file as its own module (named after its path, so two files may share a
    name), unless it is imported already (`import my_laws` before a scenario names my_laws.py):
    its registrations are there, and a second import would register them twice."""
    already = _imported_from(path)
    if already is not None:
        return already
    name = f"testbed_plugin_{path.stem}_{hashlib.sha1(str(path).encode()).hexdigest()[:8]}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    sys.path.insert(0, str(path.parent))  # the plug-in may import its neighbours, as a script would
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    finally:
        sys.path.remove(str(path.parent))
    return module

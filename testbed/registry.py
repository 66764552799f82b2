"""Named registries (systems, stages, metrics, references, commands) and their discovery.

Every kind of plug-in point is a `Registry`: entries are added by a decorator in the module
that defines them, looked up by the name a scenario gives. `discover()` imports every module
of `testbed.stages` and every package of `testbed.systems` once, so a new stage file or
system folder registers itself with no edit to any shared file.
"""

from __future__ import annotations

import importlib
import pkgutil
from typing import Any, Iterator

from testbed.errors import InputError

# Packages whose modules register entries when imported (generic stages, then systems).
PLUGIN_PACKAGES = ("testbed.stages", "testbed.systems")


class Registry:
    """name -> entry for one kind of thing; a name is registered once."""

    def __init__(self, kind: str):
        self.kind = kind
        self._entries: dict[str, Any] = {}

    def add(self, name: str, entry: Any) -> None:
        if name in self._entries:
            raise ValueError(f"{self.kind} {name!r} is registered twice")
        self._entries[name] = entry

    def lookup(self, name: Any, field: str) -> Any:
        """The entry called `name`; else InputError naming `field` and the known names."""
        if not isinstance(name, str) or name not in self._entries:
            raise InputError(field, f"unknown {self.kind} {name!r} (one of {', '.join(self.names())})")
        return self._entries[name]

    def names(self) -> list[str]:
        return sorted(self._entries)

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self._entries

    def __getitem__(self, name: str) -> Any:
        return self._entries[name]

    def items(self) -> Iterator[tuple[str, Any]]:
        return iter(self._entries.items())


_discovered = False


def discover() -> None:
    """Import every plug-in module of the package once (see module doc)."""
    global _discovered
    if _discovered:
        return
    for package_name in PLUGIN_PACKAGES:
        package = importlib.import_module(package_name)
        for info in pkgutil.iter_modules(package.__path__, package_name + "."):
            importlib.import_module(info.name)
    _discovered = True

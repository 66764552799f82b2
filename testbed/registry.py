"""Named registries: systems, stages, metrics, references, commands.

Every kind of plug-in point is a `Registry`: entries are added by a decorator in the module
that defines them (testbed.plugins imports those modules), looked up by the name a scenario
gives. A name is registered once, so nothing can shadow what is already there.
"""

from __future__ import annotations

from typing import Any, Iterator

from testbed.scenario import schema
from testbed.errors import InputError, quoted


class DuplicateName(ValueError):
    """A name registered a second time (a plug-in must not shadow a built-in or another plug-in)."""


class Registry:
    """name -> entry for one kind of thing; a name is registered once."""

    every: list["Registry"] = []  # all registries, for snapshot() / restore()

    def __init__(self, kind: str):
        self.kind = kind
        self._entries: dict[str, Any] = {}
        self._owners: dict[str, str] = {}  # name -> the module that defines what it registers
        Registry.every.append(self)

    def add(self, name: str, entry: Any, owner: str = "") -> None:
        """Register `entry` as `name`; `owner`: the module defining it (the decorated object's)."""
        if not isinstance(name, str) or not name:
            raise ValueError(f"a {self.kind} name must be a non-empty string, got {name!r}")
        if name in self._entries:
            raise DuplicateName(f"{self.kind} {name!r} is already registered")
        self._entries[name] = entry
        self._owners[name] = owner

    def lookup(self, name: Any, field: str) -> Any:
        """The entry called `name`; else InputError naming `field` and the known names."""
        if not isinstance(name, str) or name not in self._entries:
            raise InputError(field, f"unknown {self.kind} {quoted(name)} (one of {', '.join(self.names())})")
        return self._entries[name]

    def load(self, config, path: str, key: str, schema_of, keep_key: bool = False):
        """(name, validated parameters) of a `{key: NAME, ...parameters}` mapping; the entry's
        schema dataclass is schema_of(entry); `keep_key` leaves the key among the parameters."""
        if not isinstance(config, dict):
            raise InputError(path, f"must be a mapping {{{key}: NAME, ...}}, got {quoted(config)}")
        config = dict(config)
        name = config.get(key) if keep_key else config.pop(key, None)
        if name is None:
            raise InputError(f"{path}.{key}", f"is required (one of {', '.join(self.names())})")
        return name, schema.load(schema_of(self.lookup(name, f"{path}.{key}")), config, path)

    def names(self) -> list[str]:
        return sorted(self._entries)

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self._entries

    def __getitem__(self, name: str) -> Any:
        return self._entries[name]

    def items(self) -> Iterator[tuple[str, Any]]:
        return iter(self._entries.items())


def snapshot() -> list[dict]:
    """The entries of every registry now (to undo a plug-in that failed half-way)."""
    return [dict(r._entries) for r in Registry.every]


def restore(saved: list[dict]) -> None:
    """Every registry as `snapshot` saw it, but for the testbed's own entries registered since
    (a built-in module the failed plug-in imported first stays imported: its entries must stay)."""
    for registry, entries in zip(Registry.every, saved):
        registry._entries = dict(entries) | {
            name: value for name, value in registry._entries.items()
            if name not in entries and _is_testbed_module(registry._owners.get(name, ""))}
        registry._owners = {name: owner for name, owner in registry._owners.items() if name in registry._entries}


def _is_testbed_module(module: str) -> bool:
    return module == "testbed" or module.startswith("testbed.")

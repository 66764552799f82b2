"""Subcommands of `testbed` beyond run/check/list/inspect, registered by the module that owns them.

`@command(name)` registers `add_parser(subparsers)`, which adds the subcommand's parser and
sets `func=run`, with `run(args) -> exit status`; a system package may add its own (e.g. a
picture of its actuator envelope).
"""

from __future__ import annotations

from testbed.registry import Registry

COMMANDS = Registry("command")


def command(name: str):
    def register(add_parser):
        COMMANDS.add(name, add_parser)
        return add_parser

    return register

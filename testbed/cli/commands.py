"""Subcommands of `testbed`, each registered by the module that implements it.

`@command(name)` registers `add_parser(subparsers)`, which adds the subcommand's parser and
sets `func=run`, with `run(args) -> exit status`; a system package may add its own (e.g. a
picture of its actuator envelope).
"""

from __future__ import annotations

import os
import sys
from typing import Callable

from testbed.registry import Registry

COMMANDS = Registry("command")


def command(name: str):
    def register(add_parser):
        COMMANDS.add(name, add_parser)
        return add_parser

    return register


def reported(status: int, report: Callable[[], None]) -> int:
    """`status`, once `report()` has printed the command's output: a reader of stdout that went
    away (`testbed run ... | head -1`) cuts the output short but leaves the status as it is."""
    try:
        report()
        sys.stdout.flush()
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
    return status

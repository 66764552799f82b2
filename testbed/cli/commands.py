"""Subcommands of `testbed`, each registered by the module that implements it.

`@command(name)` registers `add_parser(subparsers)`, which adds the subcommand's parser and
sets `func=run`, with `run(args) -> exit status`; a system package may add its own (e.g. a
picture of its actuator envelope).
"""

from __future__ import annotations

import os
import sys
from typing import Callable

from testbed.errors import one_line
from testbed.registry import Registry

COMMANDS = Registry("command")

# A command's exit status (docs/cli.md, "Exit status"): every check passed; a check failed, a run
# diverged or failed; bad input, nothing run.
EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2


def command(name: str):
    def register(add_parser):
        COMMANDS.add(name, add_parser, add_parser.__module__)
        return add_parser

    return register


def reported(status: int, report: Callable[[], None]) -> int:
    """`status`, once `report()` has printed the command's output: a reader of stdout that went
    away (`testbed run ... | head -1`) cuts the output short, a stdout that cannot be written
    (`> /dev/full`) costs one line on stderr, and either way the status stays as it is."""
    if sys.stdout is None:  # a plug-in set it so: the command's output goes where it was to go
        sys.stdout = sys.__stdout__
    try:
        report()
        sys.stdout.flush()
    except OSError as exc:
        stdout_lost(exc)
    return status


def stdout_lost(exc: OSError) -> None:
    """After a write to stdout failed with `exc`: say why on stderr (a reader that went away is
    no error) and send the rest of stdout to /dev/null, so that nothing fails again at exit."""
    if not isinstance(exc, BrokenPipeError):
        print(f"error: stdout: {one_line(exc.strerror or exc)}", file=sys.stderr)
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())

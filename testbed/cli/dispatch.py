"""Command line: the parser of every subcommand and the exit status of a call (see README).

Exit status: 0 all checks passed, 1 a check failed or the run diverged, 2 bad input (one
line on stderr naming the field and the reason, no traceback, no output file), 130 Ctrl-C,
143 SIGTERM.
"""

from __future__ import annotations

import argparse
import signal
import sys
import warnings

from testbed.cli import campaign, describe, init, inspect_trace, list_scenarios, run
from testbed.cli.commands import COMMANDS, EXIT_BAD_INPUT, EXIT_FAILED, stdout_lost
from testbed.interrupts import Terminated, signals_as_exceptions
from testbed.errors import InputError, WriteFailed, quoted
from testbed.plugins import discover

# The built-in subcommands, in the order `testbed --help` lists them: each module registers its
# own with @command (testbed.cli.commands) when imported, as a system package does.
BUILT_IN_COMMANDS = (run, list_scenarios, inspect_trace, campaign, describe, init)


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse's own usage errors are bad input too
        raise InputError("usage", message)


def _parser(argv: list[str]) -> argparse.ArgumentParser:
    """The parser of `argv`'s command: a built-in one needs no system package imported (they
    bring MuJoCo and SciPy, `testbed list` does without them); any other command, or none
    (`testbed --help`), discovers the system packages, which may add subcommands
    (testbed.cli.commands), listed after the built-in ones."""
    parser = _Parser(prog="testbed", description="Gyrodyne (control-moment gyroscope) attitude-control testbed on MuJoCo.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    word = next((arg for arg in argv if not arg.startswith("-")), None)
    if word not in COMMANDS or COMMANDS[word].__module__ not in {module.__name__ for module in BUILT_IN_COMMANDS}:
        discover()
    order = {module.__name__: i for i, module in enumerate(BUILT_IN_COMMANDS)}
    for _, add_parser in sorted(COMMANDS.items(), key=lambda item: order.get(item[1].__module__, len(order))):
        add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """The command line; exit status 0 every check passed, 1 a check failed or the run diverged
    or a stage failed or a file could not be written, 2 bad input (one line on stderr, no file
    written), 130 Ctrl-C, 143 SIGTERM."""
    try:
        with signals_as_exceptions(), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numerical warnings never reach the terminal raw
            argv = sys.argv[1:] if argv is None else argv
            args = _parser(argv).parse_args(argv)  # --help ends here, with its own SystemExit(0)
            try:
                return args.func(args)
            except SystemExit as exc:  # plug-in code outside a stage (a system, a reference) exiting
                print(f"error: plug-in code exited the process (sys.exit({quoted(exc.code)}))", file=sys.stderr)
                return EXIT_FAILED
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except WriteFailed as exc:  # a file could not be written (a full disk): the run, if any, is lost
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Terminated as exc:
        if exc.signum == signal.SIGTERM:
            print("terminated", file=sys.stderr)
        else:
            print(f"terminated by {signal.Signals(exc.signum).name}", file=sys.stderr)
        return 128 + exc.signum
    except BrokenPipeError as exc:  # the reader of stdout went away where no command's status was known yet
        stdout_lost(exc)
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())

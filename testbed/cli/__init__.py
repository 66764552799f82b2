"""Command line: `testbed run | check | list | inspect | sweep | init | describe` (see README).

`main` is the entry point (`[project.scripts] testbed = "testbed.cli:main"`). It imports the
commands when called, so that run-time code may import `testbed.cli.interrupts` without
loading the whole command line.
"""


def main(argv: list[str] | None = None) -> int:
    """The command line's exit status for `argv` (testbed.cli.dispatch.main)."""
    from testbed.cli.dispatch import main as dispatch

    return dispatch(argv)

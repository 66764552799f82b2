"""Command line: `testbed run | check | list | inspect | sweep | init | describe` (see README);
`main` is the entry point (`[project.scripts] testbed = "testbed.cli:main"`)."""

import sys


def main(argv: list[str] | None = None) -> int:
    """The command line (testbed.cli.dispatch.main). Its modules, and MuJoCo, SciPy, Rerun and
    Dask behind them, are imported here: a Ctrl-C meanwhile is exit 130 with one line, as later."""
    try:
        from testbed.cli.dispatch import main as dispatch
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return dispatch(argv)


__all__ = ["main"]

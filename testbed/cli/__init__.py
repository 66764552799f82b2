"""Command line: `testbed run | check | list | inspect | sweep | init | describe` (see README);
`main` is the entry point (`[project.scripts] testbed = "testbed.cli:main"`)."""

from testbed.cli.dispatch import main

__all__ = ["main"]

"""`testbed list`: the shipped scenarios, each with the first line of its description."""

from __future__ import annotations

from testbed.cli.commands import EXIT_OK, command, reported
from testbed.errors import InputError


@command("list")
def add_parser(sub) -> None:
    p = sub.add_parser("list", help="list the scenarios with a one-line description")
    p.set_defaults(func=run)


def run(args) -> int:
    from testbed.scenario.yaml_reading import read_yaml
    from testbed.scenario.shipped_files import SCENARIO_DIR

    paths = sorted(SCENARIO_DIR.glob("*.yaml"))
    if not paths:  # an install without its scenario files is broken, not an empty list
        raise InputError("list", f"no scenario files (*.yaml) in {SCENARIO_DIR}")

    def report():
        for path in paths:
            try:
                description = str(read_yaml(path).get("description") or "").strip().splitlines()
            except InputError as exc:  # one broken file does not hide the others
                description = [f"(cannot be read: {exc.reason})"]
            print(f"{path.stem:28s} {description[0] if description else ''}")
    return reported(EXIT_OK, report)

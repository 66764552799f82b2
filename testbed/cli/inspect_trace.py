"""`testbed inspect`: read back a run's entities, time span, metrics and checks from its .rrd."""

from __future__ import annotations

import json
from pathlib import Path

from testbed.cli.commands import EXIT_FAILED, EXIT_OK, command, reported
from testbed.cli.run import print_checks


@command("inspect")
def add_parser(sub) -> None:
    p = sub.add_parser("inspect", help="read back a run's entities, time span, metrics and checks")
    p.add_argument("rrd")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=run)


def run(args) -> int:
    from testbed import api

    info = api.inspect(args.rrd)  # refuses an empty name, a missing, foreign or damaged file (InputError)
    path = Path(args.rrd)

    def report():
        if args.json:
            print(json.dumps(info))
            return
        result = info["result"]
        print(f"{path}: scenario {result['scenario']}, status {result['status']}, "
              f"sim_time {info['time_span_s'][0]:g} .. {info['time_span_s'][1]:g} s")
        if not info["finished"]:
            cut = f" (its last {info['cut_bytes']} bytes, a message cut short, left out)" if info["cut_bytes"] else ""
            print(f"partial: the run did not finish; this is what its trace held when it stopped{cut}")
        print("entities:")
        for entity, rows in sorted(info["entities"].items()):
            print(f"  {entity:44s} {rows} rows")
        print("metrics:")
        for name, value in result["metrics"].items():
            print(f"  {name:32s} {value:.6g}")
        print_checks([(result["scenario"], c) for c in result["checks"]])
    return reported(EXIT_OK if info["finished"] else EXIT_FAILED, report)  # a partial trace is no passed run

"""Command line: `testbed run | check | list | inspect` (see README).

Exit status: 0 all checks passed, 1 a check failed or the run diverged, 2 bad input (one
line on stderr naming the field and the reason, no traceback, no output file).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import warnings
from pathlib import Path

from testbed import api, live_view, sweep_cli, trace  # sweep_cli registers the `sweep` subcommand
from testbed import describe_command, init_command  # noqa: F401  (register `describe` and `init`)
from testbed.commands import COMMANDS, reported, stdout_lost
from testbed.errors import InputError, WriteFailed
from testbed.interrupts import Terminated, signals_as_exceptions
from testbed.json_stdout import reserved_for_json
from testbed.plugins import discover
from testbed.progress import advance_to, progress_bar
from testbed.runner import run_scenario

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse's own usage errors are bad input too
        raise InputError("usage", message)


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="testbed", description="Gyrodyne (control-moment gyroscope) attitude-control testbed on MuJoCo.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    run = sub.add_parser("run", help="run one scenario headless and write its .rrd")
    run.add_argument("scenario", help="scenario file or name in scenarios/")
    run.add_argument("--out", help="output .rrd (default runs/<scenario>.rrd)")
    run.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE",
                     help="override a scenario field (validated like the file)")
    run.add_argument("--json", action="store_true", help="print one JSON object")
    live = run.add_mutually_exclusive_group()
    live.add_argument("--view", action="store_true",
                      help="spawn the Rerun viewer and stream the run to it as it goes (the .rrd is written too)")
    live.add_argument("--connect", metavar="URL",
                      help="stream the run as it goes to a Rerun viewer or server already running, "
                           f"e.g. {live_view.VIEWER_URL.format(port=live_view.VIEWER_PORT)} (the .rrd is written too)")
    check = sub.add_parser("check", help="run scenarios and print a table of their checks")
    check.add_argument("scenarios", nargs="*", help="files or names (default: all in scenarios/)")
    check.add_argument("--out-dir", default="runs", help="where the .rrd files go")
    check.add_argument("--json", action="store_true")
    sub.add_parser("list", help="list the scenarios with a one-line description")
    inspect = sub.add_parser("inspect", help="read back a run's entities, time span, metrics and checks")
    inspect.add_argument("rrd")
    inspect.add_argument("--json", action="store_true")
    discover()  # system packages may add subcommands (testbed.commands)
    for _, add_parser in COMMANDS.items():
        add_parser(sub)
    return parser


def _run_one(name: str, overrides, out: str | None, show_progress: bool, view: bool = False, connect: str | None = None):
    scenario = api.load(name, overrides)
    out_path = trace.output_path(Path("runs") / f"{trace.file_stem(scenario.name)}.rrd" if out is None else out)
    live = _live_view(view, connect)
    result = _run_loaded(scenario, out_path, show_progress, live)
    if live is not None and not live.complete:
        print(f"note: the viewer at {live.url} did not take the whole run within {live_view.CLOSE_S:g} s; "
              f"the trace file holds it", file=sys.stderr)
    return result


def _live_view(view: bool, connect: str | None):
    """The viewer a run is streamed to besides its file (testbed.live_view): one started now
    (`--view`) or one already running at `connect`, refused before the run when there is none.
    Called after the scenario is validated."""
    if not view and connect is None:
        return None
    url = live_view.start_viewer() if view else live_view.check_reachable(connect)
    return live_view.ViewerStream(url)


def _run_loaded(scenario, out_path, show_progress: bool, live=None):
    duration = scenario.sim.duration_s
    with progress_bar(scenario.name, duration, "sim s") as bar:
        bar.disable = bar.disable or not show_progress
        # the trace is streamed, not kept: the command line needs only the metrics
        return run_scenario(scenario, out_path, progress=lambda fraction: advance_to(bar, fraction * duration),
                            live=live)


def _print_summary(result) -> None:
    print(f"scenario {result.scenario}: {result.status}, {result.sim_s:g} s simulated in {result.wall_s:.2f} s")
    if result.error:
        print(f"error: {result.error}")
    for name, value in result.metrics.items():
        print(f"  {name:32s} {value:.6g}")
    _print_checks([(result.scenario, c) for c in result.checks])
    print(f"trace: {result.rrd}")


def _print_checks(rows) -> None:
    if not rows:
        return
    print(f"{'scenario':28s} {'check':32s} {'value':>12s}  {'limit':16s} result")
    for scenario, c in rows:
        why = f"  ({c['reason']})" if "reason" in c else ""
        print(f"{scenario:28s} {c['name']:32s} {c['value']:12.4g}  {c['limit']:16s} "
              f"{'pass' if c['passed'] else 'FAIL'}{why}")


def _cmd_run(args) -> int:
    tty = sys.stderr.isatty() and not args.json
    with reserved_for_json(args.json):  # a plug-in's prints go to stderr
        result = _run_one(args.scenario, args.set, args.out, tty, args.view, args.connect)
    return reported(EXIT_OK if result.passed else EXIT_FAILED,
                    lambda: print(json.dumps(result.as_json())) if args.json else _print_summary(result))


def _cmd_check(args) -> int:
    from testbed.runner import prepare
    from testbed.shipped_files import SCENARIO_DIR

    names = args.scenarios or sorted(str(p) for p in SCENARIO_DIR.glob("*.yaml"))
    with reserved_for_json(args.json):  # a plug-in's prints go to stderr
        scenarios = [api.load(name) for name in names]  # every one valid before any runs
        for scenario in scenarios:
            prepare(scenario)
        outs = [trace.output_path(Path(args.out_dir) / f"{trace.file_stem(Path(n).stem)}.rrd", "--out-dir")
                for n in names]
        show = sys.stderr.isatty() and not args.json
        results = [_run_loaded(scenario, out, show) for scenario, out in zip(scenarios, outs)]

    def report():
        if args.json:
            print(json.dumps([r.as_json() for r in results]))
            return
        _print_checks([(r.scenario, c) for r in results for c in r.checks])
        for r in results:
            if r.error:
                print(f"{r.scenario}: {r.error}")
    return reported(EXIT_OK if all(r.passed for r in results) else EXIT_FAILED, report)


def _cmd_list(args) -> int:
    from testbed.scenario import read_yaml
    from testbed.shipped_files import SCENARIO_DIR

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


def _cmd_inspect(args) -> int:
    from testbed.trace import read_rrd

    api.read(args.rrd)  # refuses an empty name, a missing, foreign or damaged file (InputError)
    path = Path(args.rrd)
    info = read_rrd(path)

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
        _print_checks([(result["scenario"], c) for c in result["checks"]])
    return reported(EXIT_OK if info["finished"] else EXIT_FAILED, report)  # a partial trace is no passed run


def main(argv: list[str] | None = None) -> int:
    """The command line; exit status 0 every check passed, 1 a check failed or the run diverged
    or a stage failed or a file could not be written, 2 bad input (one line on stderr, no file
    written), 130 Ctrl-C, 143 SIGTERM."""
    try:
        with signals_as_exceptions(), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numerical warnings never reach the terminal raw
            args = _parser().parse_args(argv)
            builtin = {"run": _cmd_run, "check": _cmd_check, "list": _cmd_list, "inspect": _cmd_inspect}
            return builtin[args.command](args) if args.command in builtin else args.func(args)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except WriteFailed as exc:  # a file could not be written (a full disk): the run, if any, is lost
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Terminated:
        print("terminated", file=sys.stderr)
        return 143
    except BrokenPipeError as exc:  # the reader of stdout went away where no command's status was known yet
        stdout_lost(exc)
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())

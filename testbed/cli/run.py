"""`testbed run` (one scenario, its .rrd and its summary) and `testbed check` (scenarios and
a table of their checks): exit status 0 every check passed, 1 a check failed or a run diverged.
The run's machinery (MuJoCo, SciPy, Rerun behind it) is imported when a command runs, not when
the parser is built: every other command starts without it."""

from __future__ import annotations

import json
import sys

from testbed.cli.commands import EXIT_FAILED, EXIT_OK, command, reported
from testbed.cli.json_stdout import reserved_for_json
from testbed.cli.progress import advance_to, building_notice, progress_bar
from testbed.recording import live_view
from testbed.recording.output_paths import checked_output, default_output


@command("run")
def add_run_parser(sub) -> None:
    p = sub.add_parser("run", help="run one scenario headless and write its .rrd")
    p.add_argument("scenario", help="scenario file or name in scenarios/")
    p.add_argument("--out", help="output .rrd (default runs/<scenario file name>.rrd)")
    p.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE",
                     help="override a scenario field (validated like the file)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--explain", action="store_true",
                   help="give each metric's one-line meaning beside its value (JSON: a 'meanings' object)")
    live = p.add_mutually_exclusive_group()
    live.add_argument("--view", action="store_true",
                      help="spawn the Rerun viewer and stream the run to it as it goes (the .rrd is written too)")
    live.add_argument("--connect", metavar="URL",
                      help="stream the run as it goes to a Rerun viewer or server already running, "
                           f"e.g. {live_view.VIEWER_URL.format(port=live_view.VIEWER_PORT)} (the .rrd is written too)")
    p.set_defaults(func=run)


@command("check")
def add_check_parser(sub) -> None:
    p = sub.add_parser("check", help="run scenarios and print a table of their checks")
    p.add_argument("scenarios", nargs="*", help="files or names (default: all in scenarios/)")
    p.add_argument("--out-dir", default="runs", help="where the .rrd files go")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=check)


def _run_one(name: str, overrides, out: str | None, show_progress: bool, view: bool = False, connect: str | None = None):
    from testbed import api
    from testbed.run_core.plan import prepare

    with building_notice(str(name), show_progress):
        scenario = api.load(name, overrides)
        out_path = default_output(scenario.source, scenario.name, field="trace") if out is None else checked_output(out)
        plan = prepare(scenario)
    # the viewer once the scenario and the output path are checked: a refused run opens none
    live = _live_view(view, connect) if view or connect is not None else None
    result = _run_loaded(scenario, out_path, show_progress, live, prepared=plan)
    if live is not None and not live.complete:
        print(f"note: the viewer at {live.url} did not take the whole run within {live_view.CLOSE_S:g} s; "
              f"the trace file holds it", file=sys.stderr)
    return result


def _live_view(view: bool, connect: str | None):
    """The viewer a run is streamed to besides its file (testbed.recording.live_view): one started now
    (`--view`) or one already running at `connect`, refused before the run when there is none."""
    url = live_view.start_viewer() if view else live_view.check_reachable(connect)
    return live_view.ViewerStream(url)


def _run_loaded(scenario, out, show_progress: bool, live=None, prepared=None):
    from testbed import api

    duration = scenario.sim.duration_s
    with progress_bar(scenario.name, duration, "sim s") as bar:
        bar.disable = bar.disable or not show_progress
        # the trace is streamed, not kept: the command line needs only the metrics
        return api.run(scenario, out, progress=lambda fraction: advance_to(bar, fraction * duration),
                       keep_trace=False, live=live, prepared=prepared)


def _print_summary(result, explain: bool = False) -> None:
    """The run's status, each metric (with `explain` its meaning beside it), a note for each
    metric whose value looks alarming by design (testbed.metrics `caveats`), the checks."""
    from testbed.metrics import caveats, meaning

    print(f"scenario {result.scenario}: {result.status}, {result.sim_s:g} s simulated in {result.wall_s:.2f} s")
    if result.error:
        print(f"error: {result.error}")
    for name, value in result.metrics.items():
        print(f"  {name:32s} {value:<12.6g}" + (f" {meaning(name)}" if explain else "").rstrip())
    for name, caveat in caveats(result.metrics).items():
        print(f"note: {name} = {result.metrics[name]:.3g}: {caveat}")
    print_checks([(result.scenario, c) for c in result.checks])
    print(f"trace: {result.rrd}")


def _explained_json(result, explain: bool) -> dict:
    """`--json`'s object; with `explain`, also `meanings` and `notes` (name -> text)."""
    from testbed.metrics import caveats, meaning

    out = result.as_json()
    if explain:
        out |= {"meanings": {name: meaning(name) for name in result.metrics}, "notes": caveats(result.metrics)}
    return out


def print_checks(rows) -> None:
    from testbed.metrics import value_text

    if not rows:
        return
    print(f"{'scenario':28s} {'check':32s} {'value':>12s}  {'limit':16s} result")
    for scenario, c in rows:
        why = f"  ({c['reason']})" if "reason" in c else ""
        value = value_text(c["value"], c["limit"], c["passed"])
        print(f"{scenario:28s} {c['name']:32s} {value:>12s}  {c['limit']:16s} "
              f"{'pass' if c['passed'] else 'FAIL'}{why}")


def run(args) -> int:
    tty = sys.stderr.isatty() and not args.json
    with reserved_for_json(args.json):  # a plug-in's prints go to stderr
        result = _run_one(args.scenario, args.set, args.out, tty, args.view, args.connect)
    return reported(EXIT_OK if result.passed else EXIT_FAILED,
                    lambda: print(json.dumps(_explained_json(result, args.explain))) if args.json
                    else _print_summary(result, args.explain))


def check(args) -> int:
    from testbed import api
    from testbed.run_core.plan import prepare
    from testbed.scenario.shipped_files import SCENARIO_DIR

    names = args.scenarios or sorted(str(p) for p in SCENARIO_DIR.glob("*.yaml"))
    with reserved_for_json(args.json):  # a plug-in's prints go to stderr
        scenarios = [api.load(name) for name in names]  # every one valid before any runs
        plans = [prepare(scenario) for scenario in scenarios]
        outs = [default_output(s.source, s.name, args.out_dir, "--out-dir") for s in scenarios]
        show = sys.stderr.isatty() and not args.json
        results = [_run_loaded(scenario, out, show, prepared=plan)
                   for scenario, out, plan in zip(scenarios, outs, plans)]

    def report():
        if args.json:
            print(json.dumps([r.as_json() for r in results]))
            return
        print_checks([(r.scenario, c) for r in results for c in r.checks])
        for r in results:
            if r.error:
                print(f"{r.scenario}: {r.error}")
    return reported(EXIT_OK if all(r.passed for r in results) else EXIT_FAILED, report)

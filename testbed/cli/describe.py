"""`testbed describe [system|stage|metric|reference] [NAME]`: what is registered and every
parameter it takes (type, unit, default, bounds, meaning), and what each stage reads and
returns, drawn from the registries and the schema metadata validation uses (testbed.scenario.schema),
so it cannot disagree with it. `--markdown` writes the docs' reference page
(docs/parameters.md, checked by tests/test_describe.py).
"""

from __future__ import annotations

import dataclasses
import inspect
import json

from testbed.cli.commands import command, reported
from testbed.errors import InputError, quoted

KINDS = ("system", "stage", "metric", "reference", "block")
COLUMNS = ("key", "type", "unit", "default", "bounds", "meaning")


@command("describe")
def add_parser(subparsers) -> None:
    p = subparsers.add_parser("describe", help="list systems, stages, metrics, references and scenario blocks "
                                               "with their parameters")
    p.add_argument("kind", nargs="?", help=f"one of {', '.join(KINDS)} (default: all)")
    p.add_argument("name", nargs="?", help="one entry (a stage as NAME or SLOT.NAME)")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="print the entries as one JSON list")
    out.add_argument("--markdown", action="store_true", help="print the docs' reference page")
    p.set_defaults(func=run)


def _first_paragraph(text: str | None) -> str:
    return " ".join((text or "").strip().split("\n\n")[0].split())


def _parameters(params_cls) -> list[dict]:
    from testbed.scenario.schema import describe

    return describe(params_cls) if dataclasses.is_dataclass(params_cls) else []


def _stage_returns(slot: str, cls, params_cls) -> str:
    """The keys a stage returns: what its slot's interface fixes (a law's `torque`), its
    `outputs`, or those its design publishes with default parameters; an allocator's command."""
    from testbed.pipeline import INTERFACE_SHAPES

    keys = getattr(cls, "outputs", None)
    if keys is None and hasattr(cls, "design"):
        try:
            keys = cls.design(params_cls()).get("outputs")
        except Exception:  # noqa: BLE001  (a design that needs its parameters: they decide)
            keys = ["set by its parameters"]
    if isinstance(keys, str):
        keys = [f"what its {keys} is given"]
    fixed = [f"{key} {shape}" for key, shape in INTERFACE_SHAPES.get(slot, {}).items()]
    words = list(dict.fromkeys([*fixed, *(keys or [])]))
    if getattr(cls, "output", None):
        words.append(f"command `{cls.output}`")
    return ", ".join(words) or "no declared keys (its doc says)"


def _by_name(registry) -> list[tuple]:
    """(name, entry) of a registry in the order of the names: the order modules were imported in
    depends on what the process did before."""
    return [(key, registry[key]) for key in registry.names()]


def entries(kind: str | None = None, name: str | None = None, builtin_only: bool = False) -> list[dict]:
    """Every registered entry of `kind` (all kinds when None), or the one called `name`."""
    from testbed import pipeline
    from testbed.metrics import METRICS
    from testbed.plugins import discover
    from testbed.references.registry import REFERENCES
    from testbed.systems.registry import SYSTEMS

    discover()
    if kind is not None and kind not in KINDS:
        raise InputError("describe", f"unknown kind {quoted(kind)} (one of {', '.join(KINDS)})")
    found = []
    if kind in (None, "system"):
        for key, entry in _by_name(SYSTEMS):
            found.append({"kind": "system", "name": key, "module": entry.make_plant.__module__,
                          "doc": _first_paragraph(entry.make_plant.__doc__ or entry.params.__doc__),
                          "free_flying": entry.free_flying, "parameters": _parameters(entry.params)})
    if kind in (None, "stage"):
        protocols = dict(zip(pipeline.SLOTS, (pipeline.Sensor, pipeline.Estimator, pipeline.Law, pipeline.Allocator)))
        for slot in pipeline.SLOTS:
            call = next(n for n in ("measure", "estimate", "torque", "allocate") if hasattr(protocols[slot], n))
            arguments = [a for a in inspect.signature(getattr(protocols[slot], call)).parameters if a != "self"]
            reads = f"{call}({', '.join(arguments)})"
            for key, (params_cls, cls) in _by_name(pipeline.STAGES[slot]):
                found.append({"kind": "stage", "name": key, "slot": slot, "module": cls.__module__,
                              "doc": _first_paragraph(cls.__doc__), "reads": reads, "returns": _stage_returns(slot, cls, params_cls),
                              "parameters": _parameters(params_cls)})
    if kind in (None, "metric"):
        for key, entry in _by_name(METRICS):
            doc = f"{entry.doc} Note: {entry.caveat}" if entry.caveat else entry.doc
            found.append({"kind": "metric", "name": key, "module": entry.compute.__module__, "doc": doc,
                          "parameters": []})
    if kind in (None, "reference"):
        for key, entry in _by_name(REFERENCES):
            found.append({"kind": "reference", "name": key, "module": entry.prepare.__module__,
                          "doc": _first_paragraph(entry.prepare.__doc__), "systems": list(entry.systems),
                          "parameters": _parameters(entry.params)})
    if kind in (None, "block"):
        from testbed.scenario.loading import SCENARIO_BLOCKS

        for key, (params_cls, records) in SCENARIO_BLOCKS.items():
            found.append({"kind": "block", "name": key, "module": params_cls.__module__,
                          "doc": _first_paragraph(params_cls.__doc__), "records": list(records),
                          "parameters": _parameters(params_cls)})
    if builtin_only:
        found = [e for e in found if e["module"].startswith("testbed.")]
    if name is not None:
        found = [e for e in found if name in (e["name"], f"{e.get('slot')}.{e['name']}")]
        if not found:
            raise InputError("describe", f"no {kind or 'entry'} called {quoted(name)}")
    return found


def _title(entry: dict) -> str:
    where = f" ({entry['slot']})" if entry["kind"] == "stage" else ""
    return f"{entry['kind']} {entry['name']}{where}"


def _facts(entry: dict) -> list[str]:
    facts = []
    if entry["kind"] == "stage":
        facts += [f"reads: {entry['reads']}", f"returns: {entry['returns']}"]
    if entry["kind"] == "reference":
        facts.append(f"systems: {', '.join(entry['systems'])}")
    if entry.get("records"):
        facts.append(f"records: {', '.join(entry['records'])}")
    if entry["kind"] == "system" and not entry["free_flying"]:
        facts.append("not a free-flying body")
    return facts


def as_text(found: list[dict]) -> str:
    lines = []
    for entry in found:
        lines.append(f"{_title(entry)}: {entry['doc']}" if entry["doc"] else _title(entry))
        lines += [f"  {fact}" for fact in _facts(entry)]
        for row in entry["parameters"]:
            unit = f" [{row['unit']}]" if row["unit"] else ""
            bounds = f", {row['bounds']}" if row["bounds"] else ""
            meaning = f": {row['meaning']}" if row["meaning"] else ""
            lines.append(f"  {row['key']}{unit} ({row['type']}, default {row['default']}{bounds}){meaning}")
    return "\n".join(lines)


def as_markdown(found: list[dict]) -> str:
    def cell(text) -> str:
        return str(text).replace("|", "\\|").replace("*", "\\*").replace("_", "\\_") if text else ""

    lines = ["# Parameters", "",
             "Every built-in system, stage, metric and reference with its parameters, as",
             "`testbed describe` prints them (this page is its `--markdown` output: "
             "`testbed describe --markdown > docs/parameters.md`).", ""]
    for kind in KINDS:
        group = [e for e in found if e["kind"] == kind]
        if not group:
            continue
        lines += [f"## {kind.capitalize()}s", ""]
        for entry in group:
            lines += [f"### `{entry['name']}`" + (f" ({entry['slot']})" if kind == "stage" else ""), ""]
            lines += [cell(entry["doc"]), ""] if entry["doc"] else []
            lines += [f"- {cell(fact)}" for fact in _facts(entry)] + ([""] if _facts(entry) else [])
            if entry["parameters"]:
                lines += ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
                lines += ["| " + " | ".join(cell(row[c]) for c in COLUMNS) + " |" for row in entry["parameters"]]
                lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def run(args) -> int:
    found = entries(args.kind, args.name, builtin_only=args.markdown)

    def report():
        if args.json:
            print(json.dumps(found))
        elif args.markdown:
            print(as_markdown(found), end="")
        else:
            print(as_text(found))
    return reported(0, report)

"""`testbed describe`: it lists every registered entry with the parameters validation takes, and
the bounds it prints are the ones validation enforces (testbed.scenario.schema.load refuses a value just
past each one); the docs' Parameters page is its output."""

from __future__ import annotations

import dataclasses
import json
import re
import subprocess
import sys
import types
import typing
from pathlib import Path

import pytest

from testbed import pipeline
from testbed.cli import main
from testbed.cli.describe import as_markdown, entries
from testbed.errors import InputError
from testbed.plugins import discover
from testbed.scenario.schema import load
from testbed.systems.registry import SYSTEMS

DOCS_PAGE = Path(__file__).resolve().parents[1] / "docs" / "parameters.md"


def test_the_docs_parameters_page_is_describes_output():
    assert DOCS_PAGE.read_text() == as_markdown(entries(builtin_only=True)), \
        "regenerate: testbed describe --markdown > docs/parameters.md"



def test_the_parameters_page_does_not_depend_on_what_was_imported_first():
    """A process that imports one system before the others still lists them by name."""
    code = ("import testbed.systems.planar, testbed.lebedev.stage\n"
            "from testbed.cli.describe import as_markdown, entries\n"
            "print(as_markdown(entries(builtin_only=True)), end='')")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout == DOCS_PAGE.read_text()

def _keys(params_cls, path=""):
    """Every field of a schema, a nested schema's fields as dotted keys, an optional one's after
    its own key (schema.describe)."""
    hints = typing.get_type_hints(params_cls)
    keys = []
    for f in dataclasses.fields(params_cls):
        if f.init:
            optional = typing.get_origin(hints[f.name]) in (typing.Union, types.UnionType)
            options = [t for t in typing.get_args(hints[f.name]) if t is not type(None)] if optional else []
            if len(options) == 1 and dataclasses.is_dataclass(options[0]):  # an optional block
                keys += [path + f.name] + _keys(options[0], f"{path}{f.name}.")
            elif dataclasses.is_dataclass(hints[f.name]):
                keys += _keys(hints[f.name], f"{path}{f.name}.")
            else:
                keys.append(path + f.name)
            item = typing.get_args(hints[f.name])[0] if typing.get_origin(hints[f.name]) is list else None
            if item is not None and dataclasses.is_dataclass(item):  # a list of records: each item's fields
                keys += _keys(item, f"{path}{f.name}[].")
    return keys


def test_describe_stage_lists_every_registered_stage_with_every_field_of_its_schema(capsys):
    discover()
    assert main(["describe", "stage", "--json"]) == 0
    listed = {(e["slot"], e["name"]): e for e in json.loads(capsys.readouterr().out)}
    for slot in pipeline.SLOTS:
        for name, (params_cls, _) in pipeline.STAGES[slot].items():
            assert [row["key"] for row in listed.pop((slot, name))["parameters"]] == _keys(params_cls), (slot, name)
    assert not listed


def test_units_and_a_known_parameter_of_the_lebedev_observer(capsys):
    assert main(["describe", "stage", "estimator.lebedev"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("stage lebedev (estimator): ")
    assert "  reads: estimate(t, measurement, command)" in out
    assert "  startup_s [s] (float, default required, >= 0): " in out
    assert "  max_substep_s [s] (float, default 0.0001" not in out and "max_substep_s [s] (float, default 0.05, >= 0.0001)" in out


BOUND = re.compile(r"(>=|>|<=|<) (-?[0-9.e+-]+)")


def _just_past(op: str, bound: float) -> float:
    step = max(abs(bound), 1.0) * 1e-6
    return {">": bound, ">=": bound - step, "<": bound, "<=": bound + step}[op]


@pytest.mark.parametrize("kind", ["system", "stage", "reference"])
def test_every_printed_bound_is_one_validation_enforces(kind):
    """For each scalar float field with a printed bound, of every schema that loads with its
    defaults alone: a value just past the bound is refused naming that field (the bound the docs
    show is the one that holds)."""
    checked = 0
    for entry in entries(kind):
        params_cls = _params_class(entry)
        if any(row["default"] == "required" for row in entry["parameters"] if row["key"] != "system"):
            continue
        for row in entry["parameters"]:
            if "." in row["key"] or row["type"] != "float" or row["default"] == "required":
                continue
            for op, text in BOUND.findall(row["bounds"].split(" elements")[0].split("|x|")[0]):
                data = {row["key"]: _just_past(op, float(text))}
                if entry["kind"] == "system":
                    data["system"] = entry["name"]
                with pytest.raises(InputError) as refused:
                    load(params_cls, data, "p")
                assert refused.value.field == f"p.{row['key']}", (entry["name"], row, refused.value)
                checked += 1
    assert checked >= {"system": 20, "stage": 5, "reference": 0}[kind]  # 37 and 6 here: none may go missing


def _params_class(entry: dict):
    from testbed.references.registry import REFERENCES

    if entry["kind"] == "system":
        return SYSTEMS[entry["name"]].params
    if entry["kind"] == "stage":
        return pipeline.STAGES[entry["slot"]][entry["name"]][0]
    return REFERENCES[entry["name"]].params


@pytest.mark.parametrize(("argv", "field"), [(["describe", "bogus"], "describe"),
                                              (["describe", "stage", "no_such_stage"], "describe")])
def test_an_unknown_kind_or_name_is_bad_input(argv, field, capfd):
    assert main(argv) == 2
    out, err = capfd.readouterr()
    assert out == "" and len(err.splitlines()) == 1 and err.startswith(f"error: {field}: ")


def test_user_text_names_no_internal_reference(capsys):
    """What `describe` and `list` print names papers and docs pages, never the maintainers'
    notes ("SEEDS §004", "seed 003")."""
    assert main(["describe", "--json"]) == 0
    described = capsys.readouterr().out
    assert main(["list"]) == 0
    listed = capsys.readouterr().out
    for text in (described, listed):
        assert not re.search(r"SEEDS|§|\bseed 0\d\d", text), re.search(r".{60}(SEEDS|§|seed 0\d\d).{20}", text)


def test_a_metric_alarming_by_design_says_so_and_when():
    """min_scale and torque_error_rel of a rate-limited run (the flagship: 0.0446 and 0.833)
    carry their caveat; a run the limit never scaled does not print it."""
    from testbed.metrics import METRICS, caveats, meaning

    flagship = {"min_scale": 0.0446, "torque_error_rel": 0.833, "momentum_drift_rel": 1e-10}
    assert set(caveats(flagship)) == {"min_scale", "torque_error_rel"}
    assert caveats({"min_scale": 1.0, "torque_error_rel": 0.2}) == {}
    assert "direction" in caveats(flagship)["min_scale"] and "min_scale < 1" in caveats(flagship)["torque_error_rel"]
    assert meaning("torque_error_rel") == METRICS["torque_error_rel"].doc != ""


def test_describe_metric_gives_the_meaning_and_the_caveat(capsys):
    from testbed.metrics import METRICS

    assert main(["describe", "metric", "torque_error_rel"]) == 0
    shown = capsys.readouterr().out
    assert METRICS["torque_error_rel"].doc in shown and METRICS["torque_error_rel"].caveat in shown

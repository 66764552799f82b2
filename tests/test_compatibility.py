"""Every system with every stage: a scenario whose parts do not fit is refused before the run
(exit 2, one line naming the part); one whose parts fit runs (exit 0 or 1). Never a traceback,
never a crash inside a metric after the run (issue 11)."""

from __future__ import annotations

import copy

import pytest

from testbed.cli import main
from testbed.pipeline import SLOTS
from testbed.scenario.yaml_reading import read_yaml
from testbed.scenario.shipped_files import SCENARIO_DIR

import yaml

SHIPPED = {p.stem: read_yaml(p) for p in sorted(SCENARIO_DIR.glob("*.yaml"))}


def stage_examples() -> dict[str, dict[str, dict]]:
    """slot -> stage type -> a configuration of it taken from a shipped scenario."""
    seen: dict[str, dict[str, dict]] = {slot: {"none": {"type": "none"}} for slot in SLOTS}
    for data in SHIPPED.values():
        for slot, config in data.get("pipeline", {}).items():
            seen[slot].setdefault(config["type"], config)
    return seen


def system_bases() -> dict[str, dict]:
    """system -> a shipped scenario of it, cut to a few control periods."""
    bases = {}
    for data in SHIPPED.values():
        system = data["model"]["system"]
        if system in bases:
            continue
        base = copy.deepcopy(data)
        base.pop("sweep", None)
        base.pop("reference", None)
        base["checks"] = {}
        sim = base["sim"]
        period = sim.get("control_period_s", sim.get("dt_s", 0.002))
        sim["duration_s"] = 4 * period
        sim.pop("trace_period_s", None)
        bases[system] = base
    return bases


CASES = [(system, slot, stage) for system in sorted(system_bases()) for slot in SLOTS
         for stage in sorted(stage_examples()[slot])]


def test_every_system_and_every_stage_type_are_covered():
    from testbed.pipeline import STAGES
    from testbed.plugins import discover
    from testbed.systems.registry import SYSTEMS

    discover()
    assert sorted(system_bases()) == [s for s in SYSTEMS.names() if not s.startswith("test")]
    for slot in SLOTS:
        shipped = set(stage_examples()[slot])
        builtin = {name for name in STAGES[slot].names() if "." not in name}
        # stages with required parameters appear in shipped scenarios; the rest need none
        assert shipped <= builtin


@pytest.mark.slow
@pytest.mark.parametrize("system, slot, stage", CASES)
def test_a_stage_on_a_system_runs_or_is_refused_cleanly(tmp_path, capsys, system, slot, stage):
    data = copy.deepcopy(system_bases()[system])
    data.setdefault("pipeline", {})[slot] = copy.deepcopy(stage_examples()[slot][stage])
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "out" / "x.rrd"
    status = main(["run", str(path), "--out", str(out)])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err + captured.out
    assert status in (0, 1, 2)
    if status == 2:
        assert len(captured.err.strip().splitlines()) == 1 and captured.err.startswith("error: ")
        assert not out.parent.exists() or not any(out.parent.iterdir())
    else:
        assert out.is_file()

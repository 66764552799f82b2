"""A campaign's cases in batches (testbed.campaign.batches): the batched row of a case is the row
its `--case` rerun gives alone, batches hold one timing within their memory, and a batch that
overruns or loses its worker runs its cases alone."""

from __future__ import annotations

import math
import operator
import os
import time

import pytest

from test_batch_lockstep import ABS_FLOOR, BATCHED_REL
from testbed.campaign.batches import BATCH_MEMORY_BYTES, batch_timeout_s, batches, checked_batch_size
from testbed.campaign.cases import Case
from testbed.campaign.orchestration import load_cases, rerun_case
from testbed.campaign.rows import run_together
from testbed.cli import main
from testbed.errors import InputError
from testbed.run_core.timing import Timing


def same_row(alone: dict, batched: dict) -> None:
    """A batched case's row is its rerun's: every cell but the wall time, a metric to the lockstep
    tolerance (tests/test_batch_lockstep.py: the batched forms' round-off; bit for bit where every
    slot runs per world)."""
    assert batched.keys() == alone.keys()
    for key, value in alone.items():
        other = batched[key]
        if key == "wall_s":
            continue
        if isinstance(value, float):
            if math.isnan(value):
                assert math.isnan(other), key
            else:
                assert other == pytest.approx(value, rel=BATCHED_REL, abs=ABS_FLOOR), key
        else:
            assert other == value, key


# three cases each, cut short; the fault campaign's three have their fault at 12.4 to 13.6 s
@pytest.mark.parametrize("scenario, duration_s, chosen", [("lebedev_spinup_campaign", 20, [0, 1, 2]),
                                                          ("reorient_fault_campaign", 20, [1, 3, 5])])
def test_a_case_rerun_alone_gives_its_batched_row(scenario, duration_s, chosen, tmp_path):
    overrides = [f"sim.duration_s={duration_s}"]
    _, _, cases = load_cases(scenario, overrides, chosen)
    assert len(batches(cases, workers=1)) == 1  # the three cases are one batch
    rows = run_together(cases, [str(tmp_path / f"batched{i}.rrd") for i in chosen])
    for case, row in zip(cases, rows):
        _, _, rrd, alone = rerun_case(scenario, overrides, case.index, lambda name: tmp_path / "alone")
        same_row(alone, row)
        assert rrd.is_file() and (tmp_path / f"batched{case.index}.rrd").is_file()  # a trace per case
    # the cases differ: a batch that handed one world's numbers to another would not pass above
    metrics = cases[0].prepared["metrics"]
    assert len({tuple(row[name] for name in metrics) for row in rows}) == 3


def timing(dt_s: float, samples_per_tick: int = 1) -> Timing:
    return Timing(dt_s=dt_s, control_period_s=0.05, sample_period_s=0.05 / samples_per_tick, trace_period_s=0.05,
                  n_ticks=100, steps_per_tick=round(0.05 / dt_s), steps_per_sample=1,
                  samples_per_tick=samples_per_tick, trace_every=1, envelope_rows=1)


def case(index: int, run_timing: Timing | None, world_bytes: int = 2**20, plugins=()) -> Case:
    prepared = None if run_timing is None else {"timing": run_timing, "world_bytes": world_bytes}
    return Case(index, {}, {"plugins": list(plugins)}, prepared=prepared)


def indices(groups) -> list[list[int]]:
    return [[c.index for c in group] for group in groups]


def test_batches_hold_one_timing_and_the_others_run_alone():
    fine, coarse, multirate = timing(0.01), timing(0.005), timing(0.01, samples_per_tick=5)
    cases = [case(0, fine), case(1, coarse), case(2, fine), case(3, multirate), case(4, None), case(5, coarse),
             case(6, fine, plugins=["law.py"]), case(7, fine)]
    assert indices(batches(cases, workers=1)) == [[0, 2, 7], [1, 5], [3], [4], [6]]
    assert indices(batches(cases, workers=1, size=1)) == [[i] for i in range(8)]
    assert indices(batches(cases, workers=1, size=2)) == [[0, 2], [1, 5], [3], [4], [6], [7]]


def test_a_batch_fits_its_memory_and_every_worker_gets_one():
    big = BATCH_MEMORY_BYTES // 3 + 1  # two of them fit, three do not
    cases = [case(i, timing(0.01), big) for i in range(7)]
    groups = batches(cases, workers=1)
    assert [len(g) for g in groups] == [2, 2, 1, 2]  # 4 batches: ceil(7 / 2), spread evenly
    # on 2 workers, 5 cases that need 3 batches take 4 (two rounds of 2), not 3 (a last one alone)
    assert [len(g) for g in batches(cases[:5], workers=2)] == [1, 1, 2, 1]
    assert sorted(c.index for g in groups for c in g) == list(range(7))
    small = [case(i, timing(0.01)) for i in range(10)]
    assert [len(g) for g in batches(small, workers=3)] == [3, 4, 3]
    assert [len(g) for g in batches(small[:2], workers=3)] == [1, 1]


def test_a_batchs_bound_is_the_sum_of_its_cases():
    assert batch_timeout_s([60.5, 61.0, 70.25]) == 191.75
    assert batch_timeout_s([60.0, None]) is None


@pytest.mark.parametrize("text", ["0", "-2", "1.5", "many"])
def test_a_batch_size_that_is_not_a_whole_number_of_cases_is_refused(text, tmp_path, capsys):
    with pytest.raises(InputError) as refused:
        checked_batch_size(text)
    assert refused.value.field == "--batch-size" and text in refused.value.reason
    code = main(["sweep", "lebedev_spinup_campaign", f"--batch-size={text}", "--out", str(tmp_path / "out")])
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert code == 2 and err == [f"error: --batch-size: must be a whole number of cases >= 1, got '{text}'"]
    assert not (tmp_path / "out").exists()


@pytest.fixture(scope="module")
def engine():
    from testbed.campaign.engine import Engine

    with Engine(1) as started:
        yield started


def test_a_task_that_overruns_runs_as_its_parts(engine):
    """A task of 30 s with a bound of 1 s is given up once, then its two parts run instead (no
    retry of it, no CaseLost): how a batch of cases that overruns runs each case alone."""
    start = time.monotonic()
    outcomes = list(engine.results(time.sleep, [(30.0,)], lambda args: f"sleep{args[0]}",
                                   lambda args: 1.0 if args[0] > 1 else 20.0,
                                   lambda args: [(0.01,), (0.02,)] if args[0] > 1 else []))
    assert time.monotonic() - start < 25
    assert sorted(outcomes) == [((0.01,), None), ((0.02,), None)]


def test_a_task_whose_worker_dies_runs_as_its_parts(engine):
    """A task that ends its worker process is not retried (it would end it again): its parts
    run on the worker started in its place, each its own result."""
    batch = (os._exit, 3)
    outcomes = list(engine.results(operator.call, [batch], lambda args: args[0].__name__ + str(args[1]),
                                   split=lambda args: [(abs, -2), (math.sqrt, 16.0)] if args == batch else []))
    assert sorted(outcomes, key=str) == [((abs, -2), 2), ((math.sqrt, 16.0), 4.0)]

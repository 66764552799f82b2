"""The cases of a campaign grouped into batches, each one task of the engine stepped in lockstep
(testbed.batch.lockstep.Batch; docs/campaigns.md "Batches").

A batch holds cases of one timing that run at one rate; a case whose build was not read back
before the run (no timing known), a multirate case, and a case of a scenario that loads
plug-ins (code that is not the testbed's may hang or end its process: alone, that costs only
its own case) run as single cases. A batch is sized so that its worlds fit BATCH_MEMORY_BYTES
(`world_bytes`) and so that every worker gets a batch; its time bound is the sum of its cases'
bounds.
"""

from __future__ import annotations

import math

from testbed.errors import InputError, quoted
from testbed.recording.recorder import CHUNK_ROWS

# One batch's worlds, by `world_bytes` (a worker runs one batch at a time). The bound counts the
# whole arena MuJoCo reserves for each world's data (14 MiB for the 4-CMG bus), of which a step
# touches a few kB: a flagship world's resident memory is about 3.5 MB (docs/validation.md "Memory
# per world"), so 2 GiB by the bound (68 flagship worlds) is about 240 MB resident.
BATCH_MEMORY_BYTES = 2 * 2**30
# Numbers in one trace sample of a world: the shipped CMG campaigns record 60 to 90 (truth and
# the four slots' outputs); a bound, for a world whose outputs are only known once it runs.
SAMPLE_WIDTH = 256


def world_bytes(plan) -> int:
    """A bound on the memory one world of `plan` (testbed.run_core.plan.RunPlan) holds in a batch
    [bytes]: its MuJoCo model and data (the data's whole arena, as MuJoCo allocates it: 14 MiB
    for the CMG bus), the batch recorder's chunk and its copy handed to the world's recorder
    (CHUNK_ROWS x SAMPLE_WIDTH x 8 bytes each), and the histories its metrics keep (every trace
    sample of the kept signals, each at most SAMPLE_WIDTH numbers)."""
    model, data = plan.plant.model, plan.plant.data
    timing = plan.timing
    samples = timing.loop_steps // timing.trace_every + 2
    kept = SAMPLE_WIDTH if plan.kept_signals is None else min(SAMPLE_WIDTH, 4 * len(plan.kept_signals))
    return model.nbuffer + data.nbuffer + model.narena + 2 * CHUNK_ROWS * SAMPLE_WIDTH * 8 + samples * kept * 8


def batchable(case) -> bool:
    """Whether `case` (testbed.campaign.cases.Case) may run in a batch (module doc)."""
    prepared = case.prepared or {}
    return "timing" in prepared and not prepared["timing"].multirate and not case.data.get("plugins")


def batches(cases: list, workers: int, size: int | None = None) -> list[list]:
    """`cases` in batches, in case order within each: the batchable ones of one timing together,
    at most `size` a batch (None: as many as BATCH_MEMORY_BYTES holds, spread evenly over a whole
    number of rounds of `workers`, each getting at least one batch), every other case alone."""
    groups: dict = {}
    alone = []
    for case in cases:
        if batchable(case) and size != 1:
            groups.setdefault(case.prepared["timing"], []).append(case)
        else:
            alone.append([case])
    result = []
    for group in groups.values():
        cap = size or max(1, BATCH_MEMORY_BYTES // max(case.prepared["world_bytes"] for case in group))
        # as many batches as the memory asks, then a whole number of rounds of the workers: a last
        # batch alone on one worker would hold the campaign's end while the others idle
        needed = math.ceil(len(group) / cap)
        count = min(len(group), max(workers * math.ceil(needed / workers), min(workers, len(group))))
        bounds = [round(i * len(group) / count) for i in range(count + 1)]
        result += [group[a:b] for a, b in zip(bounds, bounds[1:])]
    return sorted(result + alone, key=lambda batch: batch[0].index)


def batch_timeout_s(bounds: list) -> float | None:
    """A batch's time bound [s]: the sum of its cases' bounds (None if any case has none)."""
    return None if any(bound is None for bound in bounds) else sum(bounds)


def checked_batch_size(text: str) -> int:
    """`--batch-size`'s value: a whole number of cases >= 1; InputError otherwise."""
    try:
        size = int(text)
    except ValueError:
        size = 0
    if size < 1:
        raise InputError("--batch-size", f"must be a whole number of cases >= 1, got {quoted(text)}")
    return size

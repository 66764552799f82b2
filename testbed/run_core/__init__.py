"""The run core: one run from its plan to its result (docs/architecture.md "The run core").

`plan.prepare(scenario)` builds the plant, pipeline and reference and fixes everything else a run
needs (`RunPlan`: timing, what to keep, the conservation rule, the guard's monitors);
`in_progress.RunInProgress` runs a plan through `loop` a stretch at a time, its trace going out
through `chunk_stream`, and gives a `result.RunResult`. The stages' contract, registry, output
checks and tick are `stage_contract`, `stage_registry`, `output_check` and `tick`.

The package imports nothing at its top (the scenario schema imports `timing`). It is not named
`testbed.run`: importing a subpackage of that name would replace the function `testbed.run`.
"""

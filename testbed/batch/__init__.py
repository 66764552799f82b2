"""Many worlds in lockstep (docs/architecture.md "Many worlds"): `Batch` and `run_batch` step N
runs' plans tick by tick together, the stages on (N, ...) arrays (`stage_forms`), each world's
physics, trace and result its own.

`Batch` and `run_batch` are imported when first used (PEP 562), so that a stage module giving a
batched form imports `stage_forms` without the engine, its recorder and Rerun behind it."""

import importlib

__all__ = ["Batch", "run_batch"]


def __getattr__(name: str):
    if name not in __all__:
        raise AttributeError(f"module 'testbed.batch' has no attribute {name!r}")
    value = getattr(importlib.import_module("testbed.batch.lockstep"), name)
    globals()[name] = value  # once: later lookups do not come here
    return value

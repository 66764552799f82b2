"""Many worlds in lockstep (docs/architecture.md "Many worlds"): `Batch` and `run_batch` step N
runs' plans tick by tick together, the stages on (N, ...) arrays (`stage_forms`), each world's
physics, trace and result its own."""

from testbed.batch.lockstep import Batch, run_batch

__all__ = ["Batch", "run_batch"]

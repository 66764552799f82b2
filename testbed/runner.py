"""The names a run was made of before the run core (testbed.run_core), where they now live."""

from __future__ import annotations

from testbed.run_core.in_progress import RunInProgress, one_blas_thread, run_scenario
from testbed.run_core.plan import install_stages, stage_context
from testbed.run_core.plan import prepare as plan_run
from testbed.run_core.result import STATUSES, RunData, RunResult

__all__ = ["STATUSES", "RunData", "RunInProgress", "RunResult", "install_stages", "one_blas_thread", "prepare",
           "run_scenario", "stage_context"]


def prepare(scenario, stages: dict | None = None):
    """(plant, pipeline, reference) of the run's plan (testbed.run_core.plan.prepare)."""
    plan = plan_run(scenario, stages)
    return plan.plant, plan.pipeline, plan.reference

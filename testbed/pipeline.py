"""The control pipeline's names (sensor -> estimator -> law -> allocator), where they now live:
the stage contract, the stage registry, the output checks and the tick (testbed.run_core)."""

from __future__ import annotations

from testbed.run_core.output_check import INTERFACE_SHAPES, OutputCheck
from testbed.run_core.stage_contract import (SLOTS, Allocator, Declared, Estimator, Law, MethodFailed, Sensor,
                                             Signals, StageContext, StageFailed, StageInfo, require_attitude_estimate,
                                             require_free_body)
from testbed.run_core.stage_registry import (STAGES, build, load_params, names, output_of, params_dict, stage,
                                             stage_class, stage_info, stage_infos)
from testbed.run_core.tick import Pipeline

__all__ = ["INTERFACE_SHAPES", "SLOTS", "STAGES", "Allocator", "Declared", "Estimator", "Law", "MethodFailed",
           "OutputCheck", "Pipeline", "Sensor", "Signals", "StageContext", "StageFailed", "StageInfo", "build",
           "load_params", "names", "output_of", "params_dict", "require_attitude_estimate", "require_free_body",
           "stage", "stage_class", "stage_info", "stage_infos"]

"""Open-loop stage of the CMG spacecraft: `gimbal_rate_profile` (an allocator) commands each
gimbal rate directly as a sinusoid profile, with no controller in the loop."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.pipeline import stage
from testbed.scenario.schema import param
from testbed.stages.open_loop import SinusoidProfile


@dataclass
class GimbalRateProfileParams(SinusoidProfile):
    """Gimbal rates [rad/s] per gimbal (write them with *_deg_s below for degrees)."""

    offset: list[float] = param([0.0] * 4)
    amplitude: list[float] = param([0.0] * 4)
    frequency_hz: list[float] = param([0.0] * 4, ge=0)
    phase_deg: list[float] = param([0.0] * 4)
    amplitude_deg_s: list[float] | None = None
    offset_deg_s: list[float] | None = None

    def validate(self, path: str) -> None:
        if self.amplitude_deg_s is not None:
            self.amplitude = list(np.deg2rad(self.amplitude_deg_s))
        if self.offset_deg_s is not None:
            self.offset = list(np.deg2rad(self.offset_deg_s))
        super().validate(path)


@stage("allocator", "gimbal_rate_profile", GimbalRateProfileParams)
class GimbalRateProfile:
    output = "gimbal_rates"
    needs_actuators = False

    def __init__(self, params, ctx):
        gimbals = len(getattr(ctx.description, "gimbal_axes", ()))
        if len(params.offset) != gimbals:
            raise InputError("pipeline.allocator.offset", f"gimbal_rate_profile gives {len(params.offset)} gimbal "
                                                          f"rates; model.system {ctx.system} has {gimbals} gimbals")
        self.profile = params

    def allocate(self, t, demand, estimate, actuators):
        return {"gimbal_rates": self.profile.values(t)}  # plain floats: the servo takes them as they are

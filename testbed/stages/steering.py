"""CMG steering as an allocator: wanted body torque -> gimbal-rate commands.

The cluster must deliver H' = -(M + w x H) (SEEDS §004 eq. 14, 16, body frame) through
h J(b) b' = H' (eq. 17); J, h and H are read from the compiled model (ClusterGeometry) at
the measured gimbal angles and rotor speeds. Each law of testbed.steering is a stage type:
`pinv`, `sr`, `gsr`, `minimax_lp`, `minimax`. When the best achievable max |b'_i| exceeds
b'max the demand is scaled down, keeping its direction; `scale` records the factor and
`torque_delivered` the torque the command produces on the bus.

Near-singular default: singular values of J below STAGE_RCOND = 1e-2 of the largest count as
zero (the library's own default is 1e-9). Then the demand component along the nearly singular
direction is dropped (the least-squares projection onto the well-conditioned range is
delivered) instead of asking for rates ~|H'|/sigma_min that the rate limit would answer by
scaling the whole demand towards zero (scale ~ sigma_min / sigma_max). On
reorient_near_singular (min-max) this doubled the smallest scale (0.11 -> 0.23) and cut the
torque error. `options: {rcond: ...}` overrides it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from testbed.errors import InputError
from testbed.pipeline import stage
from testbed.schema import param
from testbed.steering import LAW_OPTIONS, STEERING_LAWS

STAGE_RCOND = 1e-2  # relative singular-value cut for the stage (see module doc)


@dataclass(kw_only=True)
class SteeringParams:
    beta_rate_max_deg_s: float = param(gt=0, doc="gimbal-rate limit")
    options: dict[str, float] = field(default_factory=dict)  # law options, e.g. rcond, lambda0


class SteeringAllocator:
    output = "gimbal_rates"
    law_name = ""

    @classmethod
    def design(cls, params) -> dict:
        return {"delivered_torque": "torque_delivered"}  # the command key of the torque produced

    def __init__(self, params: SteeringParams, ctx):
        if not hasattr(ctx.description, "unit_jacobian"):
            raise InputError("pipeline.allocator.type", f"{self.law_name} steering needs a system with a "
                             "gimbal cluster (its plant describes H(beta) and dH/dbeta)")
        for option in params.options:
            if option not in LAW_OPTIONS[self.law_name]:
                allowed = ", ".join(LAW_OPTIONS[self.law_name]) or "none"
                raise InputError(f"pipeline.allocator.options.{option}",
                                 f"not an option of {self.law_name} (options: {allowed})")
        self.geometry = ctx.description
        self.law = STEERING_LAWS[self.law_name]
        self.rate_max = np.radians(params.beta_rate_max_deg_s)
        defaults = {"rcond": STAGE_RCOND} if "rcond" in LAW_OPTIONS[self.law_name] else {}
        self.options = defaults | params.options
        self._check_options()
        self.reset_statistics()

    def applied(self) -> dict:
        """The rate limit the law is given [deg/s] (testbed.readback)."""
        return {"beta_rate_max_deg_s": float(np.degrees(self.rate_max))}

    def _check_options(self) -> None:
        """Call the law once with a zero demand so a bad option value is refused before the run."""
        try:
            self.law(self.geometry.unit_jacobian(np.zeros(4)), self.geometry.h, np.zeros(3), self.rate_max,
                     **self.options)
        except InputError as exc:
            option = exc.field.removeprefix("steering.")
            raise InputError(f"pipeline.allocator.options.{option}", exc.reason) from None

    def reset_statistics(self) -> None:
        self.statistics = {"peak_gimbal_rate": 0.0, "rate_limit_violations": 0,
                           "min_singularity": np.inf, "min_scale": 1.0, "steps": 0}

    def _count(self, result) -> None:
        """Extremes over EVERY control step, whatever the trace period (read by the metrics)."""
        s = self.statistics
        peak = float(np.max(np.abs(result.beta_rate)))
        s["peak_gimbal_rate"] = max(s["peak_gimbal_rate"], peak)
        s["rate_limit_violations"] += int(np.count_nonzero(np.abs(result.beta_rate) > self.rate_max))
        s["min_singularity"] = min(s["min_singularity"], result.singularity_measure)
        s["min_scale"] = min(s["min_scale"], result.scale)
        s["steps"] += 1

    def allocate(self, t, demand, estimate, actuators):
        beta, rotor = actuators["gimbal_angle"], actuators["rotor_rate"]
        torque = np.asarray(demand.get("torque", np.zeros(3)), float)
        omega = np.asarray(estimate.get("omega", np.zeros(3)), float)
        momentum = self.geometry.momentum(beta, rotor)
        gyroscopic = np.cross(omega, momentum)
        hdot = -(torque + gyroscopic)
        options = dict(self.options)
        if self.law_name == "gsr":
            options["t"] = t
        result = self.law(self.geometry.unit_jacobian(beta), self.geometry.h, hdot, self.rate_max, **options)
        self._count(result)
        return {"gimbal_rates": result.beta_rate,
                "torque_delivered": -result.hdot_delivered - gyroscopic,
                "scale": np.array([result.scale]),
                "singularity": np.array([result.singularity_measure]),
                "rank": np.array([float(result.rank)])}


def _register(name: str) -> None:
    cls = type(f"{name}_steering", (SteeringAllocator,), {"law_name": name, "__doc__": STEERING_LAWS[name].__doc__})
    stage("allocator", name, SteeringParams)(cls)


for _name in STEERING_LAWS:
    _register(_name)

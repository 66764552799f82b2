"""The wheel allocators' shared part (`WheelAllocator`) and `wheel_pinv`: the wanted body torque as wheel
motor torques, minimum norm.

The bus takes the reaction of the wheels' momentum change, so a body torque M asks of the array
H' = A u = -(M + w x H) (docs/theory/reaction-wheels.md, eq. (RW-3)); or H' = -M when the law
compensates w x (I w + H) itself (testbed.attitude_laws.momentum_input). The minimum-norm answer
is u = A^+ H' (A^+ = A^T (A A^T)^-1, the pseudo-inverse, for an array whose axes span the three
axes). For a redundant array (n > 3) the null-space term -k (1 - A^+ A)(h - h*) adds no body
torque and steers the wheel momenta h towards h* (`preferred_momentum_nms`, default 0: the
minimum-norm momenta) at the rate k (`null_space_gain_per_s`).

Limits: each wheel's torque is bounded by its motor's (less the friction it overcomes) and by
the torque that brings it to its speed limit within one control period; when the command passes
either, the whole vector is scaled down, keeping its direction (the body torque too:
testbed.steering.rate_limit.apply_rate_bounds). `scale` records the factor. A wheel already past
its speed limit is braked back (the bounds then exclude zero).

Friction: `compensate_friction` adds the bearing friction the array's description gives
(viscous Omega + Coulomb sign(Omega)) to each motor's command, so the torque the wheel passes to
the bus is the one allocated.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.math.cross import cross3
from testbed.pipeline import stage
from testbed.scenario.schema import param
from testbed.steering.rate_limit import apply_rate_bounds
from testbed.systems.reaction_wheels.wheel_array import WheelArray

SPAN_RCOND = 1e-6  # an array whose smallest singular value is below this share of its largest spans < 3 axes
PATH = "pipeline.allocator"


@dataclass(kw_only=True)
class WheelAllocationParams:
    null_space_gain_per_s: float = param(0.0, ge=0, le=1e3, doc="k: how fast the null-space part of the wheel "
                                         "momenta goes to that of preferred_momentum_nms (0: off)")
    preferred_momentum_nms: list[float] | None = param(None, doc="h*: per wheel momentum whose null-space part "
                                                       "the array is steered to (default 0)")
    compensate_friction: bool = param(True, doc="add the bearing friction of each wheel to its motor's command")


def minimum_norm_inverse(array: WheelArray, allocator: str) -> np.ndarray:
    """A^+ (n, 3): the pseudo-inverse of the array's distribution matrix A = [a_1 ... a_n]; refuses
    an array whose spin axes do not span the three axes (for the stage `allocator`)."""
    singular = np.linalg.svd(array.distribution, compute_uv=False)
    if len(singular) < 3 or singular[-1] < SPAN_RCOND * singular[0]:
        rank = int(np.count_nonzero(singular > SPAN_RCOND * singular[0]))
        raise InputError(f"{PATH}.type", f"{allocator} needs spin axes that span three axes; model's "
                         f"{array.count} wheel(s) span {rank}")
    return np.linalg.pinv(array.distribution)


def speed_bounds(array: WheelArray, rates, period: float) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) [N m]: the torques that bring each wheel from `rates` [rad/s] to -Omega_max and
    +Omega_max in one control period `period` [s], Js (+-Omega_max - Omega) / period."""
    to_limit = array.spin_inertia / period
    return (-array.speed_max - rates) * to_limit, (array.speed_max - rates) * to_limit


def wheel_torque_bounds(array: WheelArray, rates, friction, period: float) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) [N m] of (RW-6): the allocated torque each wheel may take over one control period
    `period` [s] at speeds `rates` [rad/s]: its motor's limit less the friction `friction` the motor
    also overcomes, within its `speed_bounds`."""
    slowest, fastest = speed_bounds(array, rates, period)
    lo = np.maximum(-array.torque_max - friction, slowest)
    hi = np.minimum(array.torque_max - friction, fastest)
    return lo, np.maximum(hi, lo)


class WheelAllocator(ABC):
    """What the wheel allocators share: the array from the plant's description, the wanted array
    momentum rate H' of (RW-3), the friction fed forward, each wheel's bounds (RW-6), and the
    command and what it records. A subclass says how H' is spread over the wheels (`distribute`)."""

    output = "wheel_torques"

    @classmethod
    def design(cls, params) -> dict:
        # the command keys of the body torque delivered and of the momentum H it was computed with
        return {"delivered_torque": "torque_delivered", "internal_momentum": "momentum", "law_compensation": True}

    def __init__(self, params, ctx):
        if not isinstance(ctx.description, WheelArray):
            raise InputError(f"{PATH}.type", f"{self.type_name} needs a system with reaction wheels "
                                             f"(model.system reaction_wheels), not {ctx.system}; a bus with "
                                             "CMGs and wheels takes the allocator hybrid_split")
        self.array = ctx.description
        self.distribution = self.array.distribution
        self.inverse = minimum_norm_inverse(self.array, self.type_name)
        self.compensate_friction = params.compensate_friction
        self.period = ctx.control_period
        law = ctx.stages.get("law")
        self.adds_gyroscopic = not (law is not None and law.design.get("compensates_internal_momentum"))
        self.statistics = {"min_scale": 1.0, "steps": 0}

    @abstractmethod
    def distribute(self, wanted, rates, friction, bounds) -> tuple[np.ndarray, float]:
        """(u, k): wheel torques [N m] that deliver k H' = k `wanted` (A u = k H') within `bounds`
        (lo, hi), k in [0, 1]; `rates` the wheel speeds [rad/s], `friction` the torque fed forward [N m]."""

    def allocate(self, t, demand, estimate, actuators):
        rates = np.asarray(actuators["wheel_rate"], dtype=float)
        torque = np.asarray(demand.get("torque", np.zeros(3)), dtype=float)
        omega = np.asarray(estimate.get("omega", np.zeros(3)), dtype=float)
        momentum = self.array.momentum(rates)
        gyroscopic = cross3(omega.tolist(), momentum.tolist()) if self.adds_gyroscopic else np.zeros(3)
        friction = self.array.friction(rates) if self.compensate_friction else np.zeros(self.array.count)
        bounds = wheel_torque_bounds(self.array, rates, friction, self.period)
        allocated, scale = self.distribute(-(torque + gyroscopic), rates, friction, bounds)
        s = self.statistics
        s["min_scale"] = min(s["min_scale"], scale)
        s["steps"] += 1
        return {"wheel_torques": allocated + friction, "torque_delivered": -(self.distribution @ allocated) - gyroscopic,
                "momentum": momentum, "scale": np.array([scale])}


@stage("allocator", "wheel_pinv", WheelAllocationParams)
class WheelPseudoInverse(WheelAllocator):
    """Minimum-norm wheel torques u = A^+ H', scaled to the torque and speed limits, with optional
    null-space wheel-momentum management."""

    def __init__(self, params: WheelAllocationParams, ctx):
        super().__init__(params, ctx)
        self.null_projector = np.eye(self.array.count) - self.inverse @ self.distribution
        self.gain = params.null_space_gain_per_s
        preferred = params.preferred_momentum_nms
        if preferred is not None and len(preferred) != self.array.count:
            raise InputError(f"{PATH}.preferred_momentum_nms", f"gives {len(preferred)} momenta; "
                                                               f"the array has {self.array.count} wheels")
        self.preferred = np.zeros(self.array.count) if preferred is None else np.asarray(preferred, dtype=float)

    def distribute(self, wanted, rates, friction, bounds):
        """u = A^+ H' (RW-4) less the null-space term (RW-5), scaled into the bounds keeping its direction."""
        allocated = self.inverse @ wanted
        if self.gain:
            allocated -= self.gain * (self.null_projector @ (self.array.wheel_momentum(rates) - self.preferred))
        return apply_rate_bounds(allocated, *bounds)

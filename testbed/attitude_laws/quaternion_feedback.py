"""Law `quaternion_feedback`: the rate-limited eigen-axis quaternion feedback of Wie
("Space Vehicle Dynamics and Control", 2nd ed., 2008, sec. 7.3; Wie & Lu 1995, JGCD 18(6)):

    u = -I [c sat_L((2k/c) e) + c ω] + ω × (I ω + H),   e = vec(q_e), q_e = q_t~ ∘ q (q_e,w >= 0)

with k = ωn², c = 2 ζ ωn and the vector saturation sat_L(x) = x min(1, L/|x|), L the rate
limit: far from the target the body turns about the eigen-axis at |ω| → L, near it
I θ'' = -k I θ - c I θ' (θ = 2e), a second-order error of natural frequency ωn and damping ζ.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.attitude_laws.regulation import Regulator, TargetParams
from testbed.math.quaternion import length_column
from testbed.pipeline import stage
from testbed.scenario.schema import param


@dataclass(kw_only=True)
class QuaternionFeedbackParams(TargetParams):
    natural_frequency_rad_s: float = param(0.2, gt=0, doc="ωn of the small-error loop")
    damping_ratio: float = param(0.9, gt=0, doc="ζ of the small-error loop")
    rate_limit_deg_s: float = param(1.0, gt=0, doc="L: the eigen-axis rate far from the target")


@stage("law", "quaternion_feedback", QuaternionFeedbackParams)
class QuaternionFeedback(Regulator):
    """Rate-limited eigen-axis quaternion feedback (Wie) with w x (I w + H) compensation."""

    name = "quaternion_feedback"
    per_world = Regulator.per_world + ("k", "c", "limit")

    def __init__(self, params: QuaternionFeedbackParams, ctx):
        super().__init__(params, ctx)
        wn = params.natural_frequency_rad_s
        self.k, self.c = wn**2, 2.0 * params.damping_ratio * wn
        self.limit = np.radians(params.rate_limit_deg_s)

    def torque(self, t, inputs):
        omega = np.asarray(inputs["omega"], float)
        error = self.error(t, inputs["quat"])
        wanted = (2.0 * self.k / self.c) * error[..., 1:]
        size = length_column(wanted)
        limited = size > self.limit
        wanted = wanted * (self.limit / np.maximum(size, self.limit))  # (x 1 exactly when not limited)
        momentum = inputs["internal_momentum"]
        torque = -np.matvec(self.inertia, self.c * (wanted + omega)) + self.gyroscopic(omega, momentum)
        return self.signals(torque, error, momentum) | {"rate_limited": limited.astype(float)}

"""Law `mrp_feedback`: the MRP regulator of Schaub & Junkins ("Analytical Mechanics of Space
Systems", 4th ed., 2018, sec. 8.4, the MRP feedback law with the internal momentum):

    u = -K σ - P ω + ω × (I ω + H),   σ = vec(q_e) / (1 + q_e,w)  (q_e,w >= 0: |σ| <= 1, the shadow set)

globally asymptotically stable for scalar K, P > 0 (V = ½ ωᵀIω + 2K ln(1 + σᵀσ)). Small
errors: σ ≈ θ/4, so I θ'' = -(K/4) θ - P θ' about each principal axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.attitude_laws.regulation import Regulator, TargetParams
from testbed.pipeline import stage
from testbed.scenario.schema import param


@dataclass(kw_only=True)
class MrpFeedbackParams(TargetParams):
    gain_k_nm: float = param(gt=0, doc="K: attitude gain on the MRP error")
    gain_p_nms: float = param(gt=0, doc="P: rate gain")


@stage("law", "mrp_feedback", MrpFeedbackParams)
class MrpFeedback(Regulator):
    """MRP feedback -K sigma - P w (Schaub) with w x (I w + H) compensation."""

    name = "mrp_feedback"
    per_world = Regulator.per_world + ("k", "p")

    def __init__(self, params: MrpFeedbackParams, ctx):
        super().__init__(params, ctx)
        self.k, self.p = params.gain_k_nm, params.gain_p_nms

    def torque(self, t, inputs):
        omega = np.asarray(inputs["omega"], float)
        error = self.error(t, inputs["quat"])
        sigma = error[..., 1:] / (1.0 + error[..., :1])
        momentum = inputs["internal_momentum"]
        torque = -self.k * sigma - self.p * omega + self.gyroscopic(omega, momentum)
        return self.signals(torque, error, momentum) | {"mrp_error": sigma}

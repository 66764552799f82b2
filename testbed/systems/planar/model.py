"""Planar attitude rig (models/planar.xml): one hinge about the inertial z axis (SEEDS §001).

Avdeev & Kaptsova 2016, eq. 1-2: x = (angle, rate), x' = a x + b u + c m with u the control
and m the disturbance angular accelerations. In MuJoCo the hinge carries inertia J and two
separate inputs: the `control` motor (torque J u, from the pipeline) and the `disturbance`
integrator actuator, whose activation is the torque J m(t) and whose ctrl is its rate, so
the disturbance never mixes with the control.

Disturbance (eq. 14, per unit inertia), with switch-on times so one run can show each phase:
    m(t) = m0 H(t - t_const) + m0' (t - t_ramp) H(t - t_ramp)
(H: unit step). With both times 0 this is the paper's m = m0 + m0' t.

The initial state is part of the model block (`initial_angle_rad`, `initial_rate_rad_s`):
the scenario's `initial:` block describes a free body (3-vector rate, quaternion) and must
stay at its defaults for this system.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.scenario.shipped_files import compile_model, load_spec
from testbed.scenario.schema import param

JOINT, BODY, CONTROL, DISTURBANCE = "angle", "rig", "control", "disturbance"


@dataclass(kw_only=True)
class PlanarParams:
    """Scenario keys of `model: {system: planar, ...}`."""

    system: str = "planar"
    inertia_kg_m2: float = param(1.0, gt=0, doc="J, inertia about the hinge axis")
    initial_angle_rad: float = param(0.1, doc="x10, angle at t = 0")
    initial_rate_rad_s: float = param(0.0, doc="x20, rate at t = 0")
    disturbance_rad_s2: float = param(0.0, doc="m0, constant disturbance acceleration (torque J m0)")
    disturbance_rate_rad_s3: float = param(0.0, doc="m0', slope of the disturbance ramp")
    disturbance_start_s: float = param(0.0, ge=0, doc="t_const, when m0 switches on")
    ramp_start_s: float = param(0.0, ge=0, doc="t_ramp, when the ramp m0' (t - t_ramp) starts")

    def disturbance(self, t):
        """m(t) [rad/s^2] (eq. 14 with switch-on times), scalar or array t."""
        t = np.asarray(t, float)
        return (self.disturbance_rad_s2 * (t >= self.disturbance_start_s)
                + self.disturbance_rate_rad_s3 * np.maximum(t - self.ramp_start_s, 0.0))

    def events(self) -> list[tuple[float, str]]:
        """(time, kind) switch-ons that change the disturbance input, in time order."""
        out = []
        if self.disturbance_rad_s2:
            out.append((self.disturbance_start_s, "constant"))
        if self.disturbance_rate_rad_s3:
            out.append((self.ramp_start_s, "ramp"))
        return sorted(out)


def build(params: PlanarParams, dt: float, integrator: str) -> mujoco.MjModel:
    """Compile models/planar.xml with J, the timestep and the integrator applied through MjSpec."""
    spec = load_spec("planar.xml", dt, integrator)
    body = spec.body(BODY)
    J = params.inertia_kg_m2
    body.inertia = [J / 2, J / 2, J]  # thin disc about the hinge axis z
    body.explicitinertial = True
    return compile_model(spec)


class PlanarRig:
    """Addresses of the hinge, its two actuators and the rig body in a compiled model."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        joint = model.joint(JOINT)
        if joint.type[0] != mujoco.mjtJoint.mjJNT_HINGE:
            raise ValueError(f"joint {JOINT!r} is not a hinge")
        self.qpos_adr = int(joint.qposadr[0])
        self.dof_adr = int(joint.dofadr[0])
        self.body_id = model.body(BODY).id
        self.control_id = model.actuator(CONTROL).id
        self.disturbance_id = model.actuator(DISTURBANCE).id
        self.act_adr = int(model.actuator_actadr[self.disturbance_id])
        self.inertia = float(model.body_inertia[self.body_id][2])

    def state_views(self, data):
        """None: the rig has no free bus whose rate and attitude `Plant` could read through views."""
        return None

    def applied(self) -> dict:
        """No bus mass properties of the scenario's to read back (the rig's are the system's own)."""
        return {}

    def angle(self, data) -> float:
        return float(data.qpos[self.qpos_adr])

    def rate(self, data) -> float:
        return float(data.qvel[self.dof_adr])

    def set_state(self, data, angle: float, rate: float) -> None:
        data.qpos[self.qpos_adr] = angle
        data.qvel[self.dof_adr] = rate

    def set_control_torque(self, data, torque: float) -> None:
        data.ctrl[self.control_id] = torque

    def control_torque(self, data) -> float:
        """The torque the ideal control motor applies now (its held command) [N m]."""
        return float(data.ctrl[self.control_id])

    def disturbance_torque(self, data) -> float:
        """J m(t) [N m]: the disturbance actuator's activation (part of the state)."""
        return float(data.act[self.act_adr])

    def add_disturbance_torque(self, data, step: float) -> None:
        data.act[self.act_adr] += step

    def set_disturbance_torque_rate(self, data, rate: float) -> None:
        data.ctrl[self.disturbance_id] = rate

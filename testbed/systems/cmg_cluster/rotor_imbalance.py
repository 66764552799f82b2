"""Rotor static and dynamic imbalance as the periodic force and torque they put on the bus.

Basilisk's "simple jitter" model of a wheel (reactionWheelStateEffector, jitter simple;
docs/theory/faults.md, "Rotor imbalance"): a rotor turning at W relative to its gimbal with
static imbalance Us [kg m] and dynamic imbalance Ud [kg m^2] loads the bus with

    F = Us W^2 u(theta),    T = r x F + Ud W^2 v(theta),

u and v the rotor's body x and y axes (a frame turning with it, normal to its spin axis),
r the rotor's centre from the bus's CoM. Applied as MuJoCo's xfrc_applied on the bus, updated
every physics step with the rotor axes at the middle of the step (the angle there, W dt / 2
ahead), so the force held over a step lags by nothing and loses sinc(W dt / 2) of its
amplitude (0.4 % at 6000 rpm, dt = 0.5 ms). The model is external to MuJoCo's rotor: it does
not conserve the spacecraft's momentum (nor does Basilisk's); a physically balanced rotor
with its CoM and principal axes offset is Basilisk's "fully coupled" model, not this one.
"""

from __future__ import annotations

import mujoco
import numpy as np

from testbed.math.cross import cross3


class RotorImbalance:
    """The simple-jitter wrench of the module doc, written into data.xfrc_applied of the bus."""

    def __init__(self, bus, model, data, static, dynamic):
        self.model, self.data = model, data
        self.static = np.asarray(static, float)
        self.dynamic = np.asarray(dynamic, float)
        self.units = [i for i in range(bus.units) if self.static[i] or self.dynamic[i]]
        self.rotor_bodies = [model.body(name).id for name in bus.rotor_names]
        self.rotor_dofs = np.asarray(bus.rotor_qvel_adr)
        self.bus_body = bus.bus_body_id
        self.half_step = 0.5 * model.opt.timestep

    def wrench(self) -> np.ndarray:
        """(F, T) [N, N m], world frame, about the bus CoM, at the middle of the coming step."""
        data = self.data
        mujoco.mj_kinematics(self.model, data)
        force, torque = np.zeros(3), np.zeros(3)
        for i in self.units:
            frame = data.xmat[self.rotor_bodies[i]].reshape(3, 3)  # rotor -> world, columns x, y, z
            speed = data.qvel[self.rotor_dofs[i]]
            lead = speed * self.half_step
            u = np.cos(lead) * frame[:, 0] + np.sin(lead) * frame[:, 1]
            v = np.cos(lead) * frame[:, 1] - np.sin(lead) * frame[:, 0]
            f = self.static[i] * speed**2 * u
            force += f
            torque += cross3(data.xpos[self.rotor_bodies[i]] - data.xipos[self.bus_body], f)
            torque += self.dynamic[i] * speed**2 * v
        return np.concatenate([force, torque])

    def step(self, nstep: int, held=None) -> None:
        """`nstep` physics steps, the wrench renewed before each; `held` (6,): a wrench on the bus
        that others hold over these steps (an environment's), added to it."""
        model, data, applied = self.model, self.data, self.data.xfrc_applied[self.bus_body]
        for _ in range(nstep):
            applied[:] = self.wrench() if held is None else self.wrench() + held
            mujoco.mj_step(model, data)

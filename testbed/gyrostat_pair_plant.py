"""The leader/follower gyrostat pair (seed 003) as a plant.

The leader is the "bus" the runner knows: `omega`, `quat` and the reference check are the
leader's. Truth adds the follower's rates p and both gyrostatic moments (lambda, q). The one
actuator is the follower's rotor-momentum rate q' (`follower_moment_rate`), realised by its
rotor motors (GyrostatPair.follower_torques). The initial state of both gyrostats is part of
the system parameters; the scenario's `initial` block is not used.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.domains.gyrostat_pair import GyrostatPair, GyrostatPairParams, build
from testbed.errors import InputError
from testbed.plant import Plant
from testbed.schema import param


@dataclass(kw_only=True)
class GyrostatPairScenarioParams(GyrostatPairParams):
    leader_omega_rad_s: list[float] = param([0.1, 0.2, 0.3], length=3, doc="w(0), leader body axes")
    leader_moment_nms: list[float] = param([0.5, 1.0, 0.3], length=3, doc="lambda, held constant")
    follower_omega_rad_s: list[float] = param([0.05, 0.25, 0.0], length=3, doc="p(0)")
    follower_moment_nms: list[float] = param([0.2, -0.3, 0.4], length=3, doc="q(0)")


class GyrostatPairPlant(Plant):
    actuators = ("follower_moment_rate",)

    def __init__(self, model, params: GyrostatPairScenarioParams):
        super().__init__(GyrostatPair(model, params))
        self.domain.data = self.data
        self.params = params
        self._body = {r: int(model.body(r).id) for r in ("leader", "follower")}
        self._free = {r: int(model.joint(f"{r}_free").dofadr[0]) for r in ("leader", "follower")}
        self._quat = int(model.joint("leader_free").qposadr[0]) + 3

    def initialise(self, initial) -> None:
        if np.any(initial.omega != 0) or not np.allclose(initial.quat, [1, 0, 0, 0]):
            raise InputError("initial", "gyrostat_pair takes its initial state from model.leader_omega_rad_s, "
                             "model.follower_omega_rad_s and the moments")
        p = self.params
        self.domain.reset(p.leader_omega_rad_s, p.leader_moment_nms, p.follower_omega_rad_s, p.follower_moment_nms)

    def omega(self) -> np.ndarray:
        return self.domain.omega("leader")

    def quat(self) -> np.ndarray:
        return self.data.qpos[self._quat:self._quat + 4].copy()

    def _refresh(self) -> None:
        """Kinematics and velocities of the current state (after mj_step they lag one step)."""
        for fn in (mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_comVel, mujoco.mj_subtreeVel):
            fn(self.model, self.data)

    def angular_momentum_world(self) -> np.ndarray:
        """Sum of both gyrostats' momenta about their own centres of mass (each is conserved)."""
        self._refresh()
        return sum(self.data.subtree_angmom[b].copy() for b in self._body.values())

    def locked_inertia(self) -> np.ndarray:
        """The leader's A (rotors locked), from the rotational block of mj_fullM."""
        mujoco.mj_forward(self.model, self.data)
        full = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, full)
        a = self._free["leader"] + 3
        return full[a:a + 3, a:a + 3].copy()

    def kinetic_energy(self) -> float:
        """1/2 w.A w + 1/2 p.A p [J]: the energy of eq. (1) that is conserved while both
        gyrostatic moments are constant (the rotors' own spin energy is left out: the leader's
        speed servos do work on its rotors, so the total kinetic energy is not conserved)."""
        A = self.domain.A
        w, p = self.domain.omega("leader"), self.domain.omega("follower")
        return float(0.5 * (w @ (A * w) + p @ (A * p)))

    def internal_momentum_body(self) -> np.ndarray:
        return self.domain.moment("leader")

    def truth(self) -> dict[str, np.ndarray]:
        signals = super().truth()
        signals.update(follower_omega=self.domain.omega("follower"),
                       leader_moment=self.domain.moment("leader"),
                       follower_moment=self.domain.moment("follower"))
        return signals

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        """Synchronisation error p - w (follower minus leader rates)."""
        return {"truth/sync_error": recorder["truth/follower_omega"] - recorder["truth/omega"]}

    def apply(self, command: dict[str, np.ndarray]) -> None:
        q_dot = command.get("follower_moment_rate")
        if q_dot is not None:
            self.domain.command_follower(q_dot)

    def scene(self) -> dict:
        """The 3D view shows the leader's box (the base class looks for a body named bus)."""
        box = self.model.geom("leader_box").id
        return {"bus_half_size": list(map(float, self.model.geom_size[box])),
                "momentum_scale": 1.0 / max(self.momentum_scale(), 1e-9)}


def make_plant(params: GyrostatPairScenarioParams, sim) -> GyrostatPairPlant:
    return GyrostatPairPlant(build(params, sim.dt_s, sim.integrator), params)

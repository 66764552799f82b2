"""Stages for the leader/follower gyrostats of seed 003 (the observer of observer.py).

- sensor `leader_rates`: the leader's w1, w2 only (key `w12`); with `follower_state: true`
  also the follower's own p and q (its gyros and rotor tachometers).
- estimator `invariant_manifold`: observer (3), (8), (13) for the leader's unmeasured w3,
  arctan form (11) when A3 is the largest or smallest inertia, log form (12) when it is the
  intermediate one; gamma a parameter. The leader's A and lambda are design data (`model`).
  Between ticks the observer ODE is integrated by RK4 with w1, w2 interpolated linearly
  between the last two samples, so the estimate at t uses samples up to t only.
- estimator `pass_through`: every measured key unchanged.
- law `synchronisation`: the follower's q' = Q(w1, w2, p, q) of (15), which makes the
  follower's own equation (2) the observer system (3): p -> w at rate gamma. The command is
  held for a control period Tc, so by default (`hold: midpoint`) Q is evaluated at the state
  predicted for the middle of the hold, t + Tc/2 (p, q by the follower's own eq. 2; w1, w2
  extrapolated from the last two samples): the zero-order hold otherwise delays the law by
  Tc/2 and leaves |p - w| stalled at O(Tc) (measured 1.1e-4 rad/s at Tc = 2 ms, 5.8e-4 at
  10 ms in gyrostat_sync).
- allocator `follower_rotors`: hands q' to the follower's rotor motors.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from testbed.errors import InputError
from testbed.math.rk4 import rk4_steps
from testbed.pipeline import stage
from testbed.scenario.schema import param
from testbed.systems.gyrostat_pair.model import body_acceleration
from testbed.systems.gyrostat_pair.observer import InvariantManifoldObserver


def _require_pair(ctx, slot: str, name: str) -> None:
    if ctx.system != "gyrostat_pair":
        raise InputError(f"pipeline.{slot}.type", f"{name} needs model.system gyrostat_pair")


def make_observer(ctx, gamma: float) -> InvariantManifoldObserver:
    """The observer for the scenario's leader; bad inertias are reported on model.inertia_kg_m2."""
    model = ctx.model
    try:
        return InvariantManifoldObserver(model.inertia_kg_m2, model.leader_moment_nms, gamma)
    except InputError as exc:
        raise InputError("model.inertia_kg_m2" if exc.field.endswith("inertia") else "model.leader_moment_nms",
                         f"{exc.reason} (invariant-manifold observer, seed 003 eq. 3)") from None


@dataclass(kw_only=True)
class LeaderRatesParams:
    follower_state: bool = param(False, doc="also measure the follower's own rates p and rotor moment q")


@stage("sensor", "leader_rates", LeaderRatesParams)
class LeaderRates:
    @classmethod
    def design(cls, params: LeaderRatesParams) -> dict:
        return {"outputs": ("w12", "follower_omega", "follower_moment") if params.follower_state else ("w12",)}

    def __init__(self, params: LeaderRatesParams, ctx):
        _require_pair(ctx, "sensor", "leader_rates")
        self.follower = params.follower_state

    def measure(self, t, plant):
        out = {"w12": plant.omega()[:2]}
        if self.follower:
            out["follower_omega"] = plant.role_omega("follower")
            out["follower_moment"] = plant.moment("follower")
        return out


@stage("estimator", "pass_through")
class PassThrough:
    outputs = "measurement"  # whatever the sensor measures (testbed.pipeline.stage_infos)

    def __init__(self, params, ctx):
        pass

    def estimate(self, t, measurement, command):
        return dict(measurement)


@dataclass(kw_only=True)
class InvariantManifoldParams:
    gamma_1_s: float = param(gt=0, doc="decay rate of the manifold error eta (eq. 9)")
    initial_state_rad_s: list[float] = param([0.0, 0.0, 0.0], length=3, doc="observer state p(0)")
    substeps: int = param(2, ge=1, le=1000, doc="RK4 steps per control period (each costs about the tick's own work)")


@stage("estimator", "invariant_manifold", InvariantManifoldParams)
class InvariantManifold:
    def __init__(self, params: InvariantManifoldParams, ctx):
        _require_pair(ctx, "estimator", "invariant_manifold")
        if "w12" not in ctx.stages["sensor"].outputs:
            raise InputError("pipeline.sensor.type", "invariant_manifold reads w1, w2 from sensor leader_rates")
        self.observer = make_observer(ctx, params.gamma_1_s)
        self.p = np.asarray(params.initial_state_rad_s, float)
        self.substeps = params.substeps
        self.last = None  # (t, w1, w2) of the previous sample

    def _advance(self, t0, w0, t1, w1) -> None:
        """RK4 on p' = observer rate (3) from t0 to t1, w1 and w2 linear in between."""
        rate = self.observer.rate

        def f(s, p):
            w = w0 + (w1 - w0) * s
            return rate(w[0], w[1], p)

        self.p = rk4_steps(f, self.p, t1 - t0, self.substeps)

    def estimate(self, t, measurement, command):
        w = np.asarray(measurement["w12"], float)
        if self.last is not None and t > self.last[0]:
            self._advance(self.last[0], self.last[1], t, w)
        self.last = (t, w)
        omega = self.observer.estimate(w[0], w[1], self.p)
        return {"omega": omega, "observer_state": self.p.copy(), "manifold": np.array([omega[2] - self.p[2]])}


@dataclass(kw_only=True)
class SynchronisationParams:
    gamma_1_s: float = param(gt=0, doc="rate of the observer system the follower is made to obey")
    hold: Literal["midpoint", "none"] = param("midpoint", doc="evaluate Q at the middle of the hold")


@stage("law", "synchronisation", SynchronisationParams)
class Synchronisation:
    def __init__(self, params: SynchronisationParams, ctx):
        _require_pair(ctx, "law", "synchronisation")
        needed = {"w12", "follower_omega", "follower_moment"}
        if not needed <= ctx.stages["estimator"].outputs:
            raise InputError("pipeline.estimator.type", "synchronisation needs the measured w1, w2, p and q "
                             "passed on (estimator pass_through)")
        if not needed <= ctx.stages["sensor"].outputs:
            raise InputError("pipeline.sensor.follower_state", "synchronisation needs sensor leader_rates "
                             "with follower_state: true (the follower's own p and q)")
        self.observer = make_observer(ctx, params.gamma_1_s)
        self.half = ctx.control_period / 2 if params.hold == "midpoint" else 0.0
        self.A = self.observer.A
        self.last = None  # (t, w12) of the previous sample

    def torque(self, t, estimate):
        w = np.asarray(estimate["w12"], float)
        p, q = np.asarray(estimate["follower_omega"], float), np.asarray(estimate["follower_moment"], float)
        law = self.observer.synchronisation_law
        q_dot = law(w[0], w[1], p, q)
        if self.half:
            slope = (w - self.last[1]) / (t - self.last[0]) if self.last is not None and t > self.last[0] else 0.0
            p_dot = body_acceleration(self.A, p, q, q_dot)       # the follower's eq. (2)
            w_mid = w + self.half * slope
            q_dot = law(w_mid[0], w_mid[1], p + self.half * p_dot, q + self.half * q_dot)
        self.last = (t, w)
        return {"moment_rate": q_dot, "leader_omega_estimate": self.observer.estimate(w[0], w[1], p)}


@stage("allocator", "follower_rotors")
class FollowerRotors:
    """The follower's rotor-momentum rate q' from the law, executed by its rotor motors."""

    output = "follower_moment_rate"
    needs_actuators = False

    def __init__(self, params, ctx):
        pass

    def allocate(self, t, demand, estimate, actuators):
        return {"follower_moment_rate": np.asarray(demand.get("moment_rate", np.zeros(3)), float)}

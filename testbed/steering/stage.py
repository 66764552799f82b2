"""CMG steering as an allocator: wanted body torque -> gimbal-rate commands.

The cluster must deliver H' = -(M + w x H) (SEEDS §004 eq. 14, 16, body frame) through
h J(b) b' = H' (eq. 17), or H' = -M for a law that compensates w x (I w + H) itself
(testbed.attitude_laws.momentum_input: then `torque_delivered` is -H' too); J, h and H are read from the compiled model (ClusterGeometry) at
the measured gimbal angles and rotor speeds. Each law of testbed.steering is a stage type:
`pinv`, `sr`, `gsr`, `minimax_lp`, `minimax`, `minimax_avoid`, `osr`, `sda`, `pga`. When the best achievable
max |b'_i| exceeds b'max the demand is scaled down, keeping its direction; `scale` records the
factor, `torque_delivered` the torque the command produces on the bus, `momentum` the H it was
computed with (the rotors' spin momentum H(beta, Omega) the encoders and rotor tachometers give),
`held_momentum` the momentum the cluster holds in full (H plus the gimbal frames and rotors
turning with the gimbal rates, ClusterGeometry.held_momentum: when the actuator state has the
gimbal tachometers' `gimbal_rate` and the description the gimbal inertias) and `status` the law's
status flags as the sum of their codes (testbed.steering.result.STATUS_CODES: 1 rate_limited,
2 rank_deficient, 4 lp_failed, 8 avoidance_limited; 0 ok). What a law needs at each step beyond
J, h and H' (testbed.steering.STEP_INPUTS) comes from the clock and the cluster description:
`t` (gsr, osr); dJ_i/dbeta_i (minimax_avoid, `unit_jacobian_derivative` of the description), the
measured angles, the angles at t = 0 and J there, and the peak rate commanded so far
(minimax_avoid's pull back to the start's zero-momentum family).

Gimbal limits (optional, every law): `gimbal_angle_limits_deg` ([min, max] or null per gimbal)
and `gimbal_acceleration_max_deg_s2` become per-step bounds on each rate
(testbed.steering.gimbal_limits: braking curves from the commanded angles, which the stage
integrates from its own commands as the servos do, and the previous command), handed to the
law as `rate_bounds`. Refused before the run: a pair that is not [min, max] with min < max, a
count that is not the cluster's, a gimbal that starts outside its range. Counted at every
control step: commanded angles outside their range and commanded rate changes above
a_max Tc (1 + 1e-9, the rounding of the bounds), the peak commanded acceleration, and the
measured angles' smallest distance to a stop. The measured angle follows the commanded one
through the servo, whose stiffness gives way to the gyroscopic torque on the gimbal axis: it
can pass a stop by that compliance (up to 0.006 deg on the 30 deg/s near-singular slew, docs/theory/steering.md
"Gimbal limits").

Fault detection (optional, every law): `fault_detection: true` compares each unit's measured gimbal
rate with the command it held and its rotor speed with the nominal one (testbed.steering.fault_isolation,
thresholds `fault_rate_residual_deg_s`, `fault_rate_residual_rel`, `fault_speed_residual_rel`,
`fault_persistence`); a unit declared failed has its column of J (and of dJ/dbeta) zeroed, so the
law runs on the other units' columns, and its command pinned at 0 (a zero column takes any rate
without torque). `fault_residual` and `failed_units` are recorded; docs/theory/faults.md.

Singularity classification (every law): below `classify_below` of sqrt(det(J J^T)) the stage records
`singularity_type` (singularity_type.py: 1 hyperbolic, 2 elliptic, 3 degenerate; 0 above the
threshold) and `singular_direction` u (zeros above the threshold), by Bedrossian's test.

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
from testbed.math.cross import cross3
from testbed.pipeline import stage
from testbed.scenario.schema import join, param
from testbed.steering import FOUR_UNIT_LAWS, LAW_OPTIONS, STEERING_LAWS, STEP_INPUTS
from testbed.steering.batched_stage import ROW_LAWS, batched_form
from testbed.steering.fault_isolation import FaultIsolation
from testbed.steering.gimbal_limits import ACCELERATION_ROUNDING, GimbalLimits
from testbed.steering.result import status_code
from testbed.steering.singularity_type import NOT_SINGULAR, singularity_type

STAGE_RCOND = 1e-2  # relative singular-value cut for the stage (see module doc)
ANGLE_LIMITS = "pipeline.allocator.gimbal_angle_limits_deg"
STOP_RANGE_DEG = 360.0  # a travel stop further from zero is a gimbal without stops (null), misnamed


@dataclass(kw_only=True)
class SteeringParams:
    beta_rate_max_deg_s: float = param(gt=0, doc="gimbal-rate limit")
    gimbal_acceleration_max_deg_s2: float | None = param(None, gt=0, doc="limit on the commanded gimbal acceleration")
    gimbal_angle_limits_deg: list[list[float] | None] | None = None  # per gimbal [min, max] or null (no stops)
    options: dict[str, float] = field(default_factory=dict)  # law options, e.g. rcond, lambda0
    # fault detection and isolation (fault_isolation.py, docs/theory/faults.md)
    fault_detection: bool = param(False, doc="detect and isolate a failed unit, then steer on the others")
    fault_rate_residual_deg_s: float = param(0.2, gt=0, doc="a: absolute part of the gimbal-rate threshold")
    fault_rate_residual_rel: float = param(0.5, ge=0, lt=1, doc="rho: share of |command| added to the rate threshold")
    fault_speed_residual_rel: float = param(0.01, gt=0, lt=1, doc="sigma: rotor-speed threshold, share of nominal")
    fault_persistence: int = param(3, ge=1, le=1000, doc="consecutive control ticks over threshold before isolation")
    max_failed_units: int = param(1, ge=1, le=10, doc="most units dropped (the rest must keep rank 3)")
    # Bedrossian's test below this sqrt(det(J J^T)) (singularity_type.py): allocator/singularity_type, singular_direction
    classify_below: float = param(0.05, ge=0, doc="singularity measure below which the state is classified")

    def validate(self, path: str) -> None:
        for i, pair in enumerate(self.gimbal_angle_limits_deg or []):
            field_path = join(path, f"gimbal_angle_limits_deg[{i}]")
            if pair is not None and len(pair) != 2:
                raise InputError(field_path, "must be [min, max] in deg, or null for no stops")
            if pair is not None and not pair[0] < pair[1]:
                raise InputError(field_path, f"min {pair[0]:g} deg must be below max {pair[1]:g} deg")
            if pair is not None and max(abs(pair[0]), abs(pair[1])) > STOP_RANGE_DEG:
                raise InputError(field_path, f"a stop lies within one turn of zero (+-{STOP_RANGE_DEG:g} deg), "
                                 f"got [{pair[0]:g}, {pair[1]:g}]; null is a gimbal without stops")


def configured_limits(params: SteeringParams, ctx, gimbals: int) -> GimbalLimits | None:
    """The limits of `params` for a cluster of `gimbals`, checked against the angles the encoders
    report at t = 0 (ctx.actuators); None when there are none."""
    pairs, acceleration = params.gimbal_angle_limits_deg, params.gimbal_acceleration_max_deg_s2
    if pairs is None and acceleration is None:
        return None
    if pairs is not None and len(pairs) != gimbals:
        raise InputError(ANGLE_LIMITS, f"gives {len(pairs)} gimbals; the cluster has {gimbals}")
    pairs = pairs or [None] * gimbals
    low = np.radians([-np.inf if p is None else p[0] for p in pairs])
    high = np.radians([np.inf if p is None else p[1] for p in pairs])
    start = ctx.actuators.get("gimbal_angle")
    if start is not None:
        for i, (angle, a, b) in enumerate(zip(start, low, high)):
            if not a <= angle <= b:
                raise InputError(f"{ANGLE_LIMITS}[{i}]", f"gimbal {i + 1} starts at {np.degrees(angle):.6g} deg, "
                                 f"outside [{np.degrees(a):g}, {np.degrees(b):g}] deg")
    return GimbalLimits(low, high, np.inf if acceleration is None else np.radians(acceleration),
                        ctx.control_period)


class SteeringAllocator:
    output = "gimbal_rates"
    law_name = ""
    four_units_only = ""  # why the allocator steers 4-unit clusters only; "": any cluster

    @classmethod
    def design(cls, params) -> dict:
        # the command keys of the torque produced, of the momentum H the command was computed with
        # and of the momentum the cluster holds in full (see the module doc), and the gimbal-rate
        # limit [rad/s] the law keeps (what torque the cluster can give: momentum_gauge)
        return {"delivered_torque": "torque_delivered", "internal_momentum": "momentum",
                "held_momentum": "held_momentum", "law_compensation": True,
                "gimbal_rate_limit": float(np.radians(params.beta_rate_max_deg_s))}

    def __init__(self, params: SteeringParams, ctx):
        if not hasattr(ctx.description, "unit_jacobian"):
            raise InputError("pipeline.allocator.type", f"{self.law_name} steering needs a system with a "
                             "gimbal cluster (its plant describes H(beta) and dH/dbeta); a bus with CMGs and "
                             "wheels takes the allocator hybrid_split")
        user_options = [name for name in LAW_OPTIONS[self.law_name] if name not in STEP_INPUTS]
        for option in params.options:
            if option not in user_options:
                raise InputError(f"pipeline.allocator.options.{option}",
                                 f"not an option of {self.law_name} (options: {', '.join(user_options) or 'none'})")
        self.step_inputs = STEP_INPUTS.intersection(LAW_OPTIONS[self.law_name])
        if "column_derivative" in self.step_inputs and not hasattr(ctx.description, "unit_jacobian_derivative"):
            raise InputError("pipeline.allocator.type", f"{self.law_name} steering needs a cluster description "
                             "with dJ_i/dbeta_i (unit_jacobian_derivative)")
        self.geometry = ctx.description
        # a law that compensates w x H itself (testbed.attitude_laws.momentum_input): not added here
        law = ctx.stages.get("law")
        self.adds_gyroscopic = not (law is not None and law.design.get("compensates_internal_momentum"))
        self.law = STEERING_LAWS[self.law_name]
        self.rate_max = np.radians(params.beta_rate_max_deg_s)
        self.period = ctx.control_period
        gimbals = len(self.geometry.gimbal_axes)
        if self.four_units_only and gimbals != 4:
            raise InputError("pipeline.allocator.type", f"{self.stage_name()} steers 4-unit clusters only "
                             f"({self.four_units_only}); this array has {gimbals} units")
        self.limits = configured_limits(params, ctx, gimbals)
        # the angles the run starts from and J there (minimax_avoid's preferred configuration)
        start = ctx.actuators.get("gimbal_angle")
        self.start = np.zeros(gimbals) if start is None else np.array(start, dtype=float)
        self.start_jacobian = self.geometry.unit_jacobian(self.start)
        self.setpoint = None  # commanded gimbal angles, from the first measurement on
        self.previous = np.zeros(gimbals)  # the gimbals start at rest
        defaults = {"rcond": STAGE_RCOND} if "rcond" in LAW_OPTIONS[self.law_name] else {}
        self.options = defaults | params.options
        self._check_options()
        self.classify_below = params.classify_below
        self.classifies = hasattr(self.geometry, "unit_jacobian_derivative")
        self.isolation = FaultIsolation(params, gimbals, getattr(
            self.geometry, "nominal_rotor_speed", None)) if params.fault_detection else None
        self.reset_statistics()

    @classmethod
    def stage_name(cls) -> str:
        """The allocator's name in a scenario."""
        return cls.law_name

    def applied(self) -> dict:
        """The rate limit the law is given [deg/s] (testbed.campaign.applied_values)."""
        return {"beta_rate_max_deg_s": float(np.degrees(self.rate_max))}

    def _inputs(self, t: float, beta: np.ndarray) -> dict:
        """The step inputs (STEP_INPUTS) this law takes, at time t and gimbal angles beta."""
        inputs = {}
        if "t" in self.step_inputs:
            inputs["t"] = t
        if "column_derivative" in self.step_inputs:
            inputs["column_derivative"] = self.geometry.unit_jacobian_derivative(beta)
        if "gimbal_angle" in self.step_inputs:
            inputs["gimbal_angle"] = beta
        if "preferred_gimbal_angles" in self.step_inputs:
            inputs["preferred_gimbal_angles"] = self.start
        if "preferred_jacobian" in self.step_inputs:
            inputs["preferred_jacobian"] = self.start_jacobian
        if "peak_rate_so_far" in self.step_inputs:  # 0 before the first step (the options check)
            inputs["peak_rate_so_far"] = getattr(self, "statistics", {}).get("peak_gimbal_rate", 0.0)
        return inputs

    def _check_options(self) -> None:
        """Call the law once with a zero demand so a bad option value is refused before the run."""
        beta = np.zeros(len(self.geometry.gimbal_axes))
        try:
            self.law(self.geometry.unit_jacobian(beta), self.geometry.h, np.zeros(3), self.rate_max,
                     **self.options, **self._inputs(0.0, beta))
        except InputError as exc:
            option = exc.field.removeprefix("steering.")
            raise InputError(f"pipeline.allocator.options.{option}", exc.reason) from None

    def reset_statistics(self) -> None:
        self.statistics = {"peak_gimbal_rate": 0.0, "rate_limit_violations": 0,
                           "min_singularity": np.inf, "min_scale": 1.0, "steps": 0,
                           "peak_gimbal_acceleration": 0.0, "acceleration_violations": 0,
                           "angle_limit_violations": 0, "min_angle_margin": np.inf}
        if self.isolation is not None:
            self.statistics.update(self.isolation.statistics)

    def _count(self, result, beta) -> None:
        """Extremes over EVERY control step, whatever the trace period (read by the metrics);
        `beta`: the measured gimbal angles the command was computed at (before the set-point moves).
        Plain floats: for four gimbals they cost a fraction of numpy's reductions, and the
        extremes and counts are the same numbers."""
        s = self.statistics
        rates = np.asarray(result.beta_rate, dtype=float).tolist()
        s["peak_gimbal_rate"] = max(s["peak_gimbal_rate"], max(map(abs, rates)))
        s["rate_limit_violations"] += sum(abs(r) > self.rate_max for r in rates)
        s["min_singularity"] = min(s["min_singularity"], result.singularity_measure)
        s["min_scale"] = min(s["min_scale"], result.scale)
        change = [abs(r - p) for r, p in zip(rates, np.asarray(self.previous, dtype=float).tolist())]
        s["peak_gimbal_acceleration"] = max(s["peak_gimbal_acceleration"], max(change) / self.period)
        if self.limits is not None:
            step = self.limits.rate_step * (1.0 + ACCELERATION_ROUNDING)
            s["acceleration_violations"] += sum(c > step for c in change)
            commanded = self.setpoint + self.period * result.beta_rate
            s["angle_limit_violations"] += int(np.count_nonzero((commanded < self.limits.angle_min)
                                                                | (commanded > self.limits.angle_max)))
            margin = np.minimum(beta - self.limits.angle_min, self.limits.angle_max - beta)
            s["min_angle_margin"] = min(s["min_angle_margin"], float(np.min(margin)))
        s["steps"] += 1

    def _classified(self, measure, jacobian, beta, momentum, failed=()):
        """(kind code, singular direction u) by Bedrossian's test when the measure is below
        `classify_below` (singularity_type.py), else (NOT_SINGULAR, zeros); a failed unit's column
        is zero in J and in dJ/dbeta alike."""
        if not self.classifies or measure >= self.classify_below:
            return np.array([float(NOT_SINGULAR)]), np.zeros(3)
        derivative = self.geometry.unit_jacobian_derivative(beta)
        derivative[:, list(failed)] = 0.0
        kind = singularity_type(jacobian, derivative, momentum)
        return np.array([float(kind.kind)]), kind.direction

    def allocate(self, t, demand, estimate, actuators):
        beta, rotor = actuators["gimbal_angle"], actuators["rotor_rate"]
        torque = np.asarray(demand.get("torque", np.zeros(3)), float)
        omega = np.asarray(estimate.get("omega", np.zeros(3)), float)
        momentum = self.geometry.momentum(beta, rotor)
        gyroscopic = cross3(omega.tolist(), momentum.tolist()) if self.adds_gyroscopic else np.zeros(3)
        hdot = -(torque + gyroscopic)
        inputs = self._inputs(t, beta)
        if self.limits is not None:
            if self.setpoint is None:
                self.setpoint = np.array(beta, dtype=float)
            inputs["rate_bounds"] = self.limits.rate_bounds(self.setpoint, self.previous, self.rate_max)
        jacobian = self.geometry.unit_jacobian(beta)
        failed = ()
        if self.isolation is not None:
            residual = self.isolation.update(t, self.previous, actuators)
            self.statistics.update(self.isolation.statistics)
            failed = self.isolation.failed
            if failed:  # the law runs on the other units' columns (fault_isolation.py)
                jacobian[:, failed] = 0.0
                if "column_derivative" in inputs:
                    inputs["column_derivative"][:, failed] = 0.0
        result = self.law(jacobian, self.geometry.h, hdot, self.rate_max, **self.options, **inputs)
        if failed:  # a zero column takes any rate without torque: pin the failed units' at 0
            result.beta_rate = np.array(result.beta_rate, dtype=float)
            result.beta_rate[failed] = 0.0
        self._count(result, beta)
        # the full momentum (ClusterGeometry.held_momentum): the spin momentum above plus the turning gimbals'
        held = (momentum + self.geometry.turning_momentum(actuators["gimbal_rate"])
                if "gimbal_rate" in actuators and hasattr(self.geometry, "turning_momentum") else momentum)
        self.previous = result.beta_rate
        if self.setpoint is not None:  # the servos integrate the held command into their set-point
            self.setpoint = self.setpoint + self.period * result.beta_rate
        command = {"gimbal_rates": result.beta_rate,
                   "torque_delivered": -result.hdot_delivered - gyroscopic,
                   "momentum": momentum,
                   "held_momentum": held,
                   "scale": np.array([result.scale]),
                   "singularity": np.array([result.singularity_measure]),
                   "rank": np.array([float(result.rank)]),
                   "status": np.array([float(status_code(result.status))])}
        command["singularity_type"], command["singular_direction"] = self._classified(
            result.singularity_measure, jacobian, beta, momentum, failed)
        if self.isolation is not None:
            command["fault_residual"] = residual
            command["failed_units"] = (~self.isolation.healthy).astype(float)
        return command


def _register(name: str) -> None:
    attributes = {"law_name": name, "__doc__": STEERING_LAWS[name].__doc__,
                  "four_units_only": FOUR_UNIT_LAWS.get(name, "")}
    if name in ROW_LAWS:  # its form on many worlds (testbed.batch): this class's allocate, a row per world
        attributes["batched"] = classmethod(lambda cls, stages: batched_form(stages))
    cls = type(f"{name}_steering", (SteeringAllocator,), attributes)
    stage("allocator", name, SteeringParams)(cls)


for _name in STEERING_LAWS:
    _register(_name)

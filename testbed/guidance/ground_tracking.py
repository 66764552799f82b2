"""The `ground_tracking` law: point a body boresight at ground targets in turn, slewing between
them, with the tracking law (testbed.guidance.tracking_law).

Each target is a WGS-84 geodetic point (testbed.orbit.ground_site). Tracking it, the target
attitude is Λ*(t) = q_look(t) ∘ q_offset: the look frame (testbed.guidance.line_of_sight_frame)
has z on the line of sight ρ = r_target - r (so the body axis that `quat` puts on the frame's z,
body z by default, is the boresight) and y along the part of -h (h = r × v, the orbit normal)
across it: at nadir it is the LVLH frame. Its rate and acceleration are exact from
ρ' = v_target - v and ρ'' = a_target - a (a: two-body + J2 gravity), h' = r × a and
h'' = v × a - μ h / r³ (the J2 jerk left out, < 1e-9 rad/s²), all from the law's own copy of
the orbit (an on-board ephemeris). Target k's slew starts at its `start_s` (the first at t = 0,
from the initial state) and runs `slew_s`: the program of SEEDS §004 stage 1
(testbed.guidance.program_trajectory) from the attitude and rate being tracked (or the initial
ones) to the new target's look attitude and rate at the slew's end, so the hand-over is
continuous in attitude and rate.

Below the horizon: the line of sight goes on through the Earth, so the law keeps pointing at
the target (it is on it when the target rises) and flags `law/tracking` 0 whenever the
spacecraft is below `min_elevation_deg` of the target's horizon, during a slew, or within
`settle_s` after one; a target that never rises above that elevation in its window is refused
at load. Records `law/torque`, `target_quat`, `target_omega`, `attitude_error` [rad],
`error_angle` [rad], `elevation` [rad] (of the spacecraft above the current target's horizon),
`target_index` and `tracking` (docs/theory/environment.md, "Ground targets"). A target whose
slew would begin at or after the run's end is not flown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.guidance.line_of_sight_frame import look_frame
from testbed.guidance.program_trajectory import ProgramTrajectory
from testbed.guidance.tracking_law import TrackingLaw
from testbed.math.cross import cross3
from testbed.math.quaternion import quat_conj, quat_rotate, rotation_vector
from testbed.math.validation import unit_quaternion
from testbed.orbit.constants import MU_EARTH_M3_S2
from testbed.orbit.gravity import acceleration
from testbed.orbit.ground_site import GroundSite, elevation
from testbed.pipeline import require_attitude_estimate, require_free_body, stage
from testbed.scenario.schema import join, param

LAW_PATH = "pipeline.law"
VISIBILITY_SAMPLES = 2000   # the load-time check samples each target's window this many times at most


@dataclass(kw_only=True)
class GroundTargetParams:
    latitude_deg: float = param(ge=-90, le=90, doc="geodetic latitude (WGS-84)")
    longitude_deg: float = param(ge=-180, le=360, doc="longitude, east positive")
    altitude_m: float = param(0.0, ge=-500, le=1e5, doc="height above the WGS-84 ellipsoid")
    start_s: float = param(0.0, ge=0, doc="when the slew to this target begins (the first target's: 0)")


@dataclass(kw_only=True)
class GroundTrackingParams:
    targets: list[GroundTargetParams] = param(doc="the ground targets, tracked in turn")
    slew_s: float = param(30.0, gt=0, le=3600, doc="duration of each slew onto a target")
    settle_s: float = param(10.0, ge=0, doc="time after a slew before law/tracking is 1")
    min_elevation_deg: float = param(10.0, ge=-90, lt=90, doc="the spacecraft's elevation above a target's "
                                     "horizon below which law/tracking is 0")
    quat: list[float] = param([1.0, 0.0, 0.0, 0.0], length=4, doc="attitude (w, x, y, z), body to look frame "
                              "(z on the line of sight, y across it toward -orbit normal): identity puts body z on it")
    natural_frequency_rad_s: float = param(0.5, gt=0, doc="tracking-error natural frequency")
    damping_ratio: float = param(0.9, ge=0, doc="tracking-error damping ratio")

    def validate(self, path: str) -> None:
        self.quat = list(unit_quaternion(join(path, "quat"), self.quat))
        if not self.targets:
            raise InputError(join(path, "targets"), "give at least one target")
        if self.targets[0].start_s != 0.0:
            raise InputError(join(path, "targets[0].start_s"), "the first target's slew starts at t = 0 "
                             "(from the initial state): leave it out or give 0")
        for i in range(1, len(self.targets)):
            earliest = self.targets[i - 1].start_s + self.slew_s
            if self.targets[i].start_s < earliest:
                raise InputError(join(path, f"targets[{i}].start_s"), f"must be >= {earliest:g} s: the slew onto "
                                 f"the previous target ends then (its start_s + slew_s)")


class LookAtSite:
    """Λ*(t), ω*(t), ω*'(t) of the body held at `offset` in the look frame of `site` from `orbit`
    (the module doc), and the spacecraft's elevation above the site's horizon."""

    def __init__(self, site: GroundSite, orbit, offset, j2: bool):
        self.site, self.orbit, self.j2 = site, orbit, j2
        self.offset = np.asarray(offset, float)
        self.to_body = quat_conj(self.offset)
        self._last = (None, None, None)

    def geometry(self, t):
        """(look-frame quaternion (w, x, y, z), ω, ω' in its axes, elevation [rad]) at t [s]."""
        if self._last[0] == t:  # the law and its record ask for one instant twice
            return self._last[1]
        r, v = self.orbit.state(t)
        a = np.array(acceleration(*r) if self.j2 else acceleration(*r, 0.0))
        site, site_v, site_a, up = self.site.state(t)
        h = cross3(r, v)
        normal = (-h, -cross3(r, a), MU_EARTH_M3_S2 / float(r @ r) ** 1.5 * h - cross3(v, a))
        frame, rate, rate_change = look_frame((site - r, site_v - v, site_a - a), normal)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, frame.ravel())
        target = np.empty(4)
        mujoco.mju_mulQuat(target, quat, self.offset)
        held = target, quat_rotate(self.to_body, rate), quat_rotate(self.to_body, rate_change)
        self._last = (t, (quat, rate, rate_change, elevation(site, up, r)), held)
        return self._last[1]

    def state(self, t):
        """(Λ*, ω*, ω*') at t [s]: the look frame's turned by the offset (body axes)."""
        self.geometry(t)
        return self._last[2]


class TargetSchedule:
    """The program of the whole run: slews onto each target in turn and the looks between."""

    def __init__(self, looks, starts, slew_s: float, initial_quat, initial_omega):
        self.looks, self.starts, self.slew = looks, list(starts), slew_s
        self.slews = []
        previous = None
        for i, (look, start) in enumerate(zip(looks, self.starts)):
            q0, w0 = (initial_quat, initial_omega) if previous is None else previous.state(start)[:2]
            q1, w1, _ = look.state(start + slew_s)
            try:
                self.slews.append(ProgramTrajectory.from_boundary(q0, w0, q1, w1, slew_s))
            except InputError as exc:
                raise InputError(join(LAW_PATH, f"targets[{i}].start_s"), exc.reason) from None
            previous = look

    def index(self, t: float) -> int:
        """The target being slewed onto or tracked at t."""
        return max(0, int(np.searchsorted(self.starts, t, side="right")) - 1)

    def state(self, t):
        k = self.index(t)
        tau = t - self.starts[k]
        return self.slews[k].state(tau) if tau < self.slew else self.looks[k].state(t)


@stage("law", "ground_tracking", GroundTrackingParams)
class GroundTracking:
    """Track ground targets in turn (module doc)."""

    def __init__(self, params: GroundTrackingParams, ctx):
        require_free_body(ctx, "law", "ground_tracking")
        require_attitude_estimate(ctx, "the ground_tracking law")
        if ctx.orbit is None:
            raise InputError(join(LAW_PATH, "targets"), "ground targets need an orbit: add an orbit: block")
        j2 = ctx.orbit.tle is not None or ctx.orbit.j2
        epoch, orbit = ctx.orbit.epoch(), ctx.orbit.propagator()   # one on-board ephemeris for every target
        flown = [p for p in params.targets if p.start_s < ctx.end_time]   # the others' slews never begin
        self.looks = [LookAtSite(GroundSite(math.radians(p.latitude_deg), math.radians(p.longitude_deg),
                                            p.altitude_m, epoch), orbit, params.quat, j2)
                      for p in flown]
        starts = [p.start_s for p in flown]
        self.min_elevation = math.radians(params.min_elevation_deg)
        self._check_visible(starts, params.slew_s, ctx.end_time)
        self.schedule = TargetSchedule(self.looks, starts, params.slew_s, ctx.initial.quat, ctx.initial.omega)
        self.track_from = [s + params.slew_s + params.settle_s for s in starts]
        try:
            self.tracking = TrackingLaw(self.schedule, ctx.inertia, params.natural_frequency_rad_s,
                                        params.damping_ratio)
        except InputError as exc:
            raise InputError(join(LAW_PATH, exc.field.rpartition(".")[2]), exc.reason) from None

    def _check_visible(self, starts, slew_s: float, end_time: float) -> None:
        """Refuse a target the spacecraft never sees above min_elevation_deg while it is tracked."""
        for i, look in enumerate(self.looks):
            first = starts[i] + slew_s
            last = min(end_time, starts[i + 1] if i + 1 < len(starts) else end_time)
            if last <= first:
                continue
            times = np.linspace(first, last, int(min(VISIBILITY_SAMPLES, (last - first) + 2)))
            highest = max(look.geometry(t)[3] for t in times)
            if highest < self.min_elevation:
                raise InputError(join(LAW_PATH, f"targets[{i}]"), f"never rises above min_elevation_deg "
                                 f"({math.degrees(self.min_elevation):g}) while tracked, {first:g}-{last:g} s: "
                                 f"highest {math.degrees(highest):.3g} deg")

    def torque(self, t, estimate):
        torque, dq, _ = self.tracking.torque_and_errors(t, estimate["quat"], estimate["omega"])
        error = rotation_vector(dq)
        q_p, w_p, _ = self.schedule.state(t)
        k = self.schedule.index(t)
        height = self.looks[k].geometry(t)[3]
        tracking = t >= self.track_from[k] and height >= self.min_elevation
        return {"torque": torque, "target_quat": q_p, "target_omega": w_p, "attitude_error": error,
                "error_angle": np.array([np.linalg.norm(error)]), "elevation": np.array([height]),
                "target_index": np.array([float(k)]), "tracking": np.array([1.0 if tracking else 0.0])}

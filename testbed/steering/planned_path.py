"""A gimbal path planned before the slew for a known momentum program H_w(t) (docs/theory/steering.md
"Planned paths").

A law that sees only the present gimbal angles must fail somewhere in the outer band of the envelope
(elliptic singular states, singularity_type.py); one that knows H_w(t) ahead can choose, before the
slew, where on each null-motion fibre H(beta) = H_w(t) the gimbals should be. The plan is the path

    beta' = J^+(beta) H_w'(t) / h + c(t) n(beta) / |n(beta)|,                                (1)

n the null vector of the 3x4 J with n_i = (-1)^i det(J without column i) (smooth in beta, and
|n| = sqrt(det(J J^T)) by Cauchy-Binet), c(t) the null-motion rate [rad/s], piecewise linear over
`knots` values, flown from the start set moved first by s [rad] along its null-motion fibre
(eq. (1) with H_w' = 0 and c = s over 1 s: null motion at rest, the reconfiguration Vadali's
preferred gimbal angles make before a manoeuvre, preferred_gimbal_angles.py). s is first chosen on a
grid of `offsets` with c = 0, then (s, c) by scipy.optimize.minimize (Powell) to minimise

    sum_k dt [ (max(0, m_target - m_k) / m_target)^2 + (max(0, max_i |beta'_i| / beta'max - 1))^2 ]
        + 1e-4 sum_j (c_j / beta'max)^2,                                                     (2)

m = sqrt(det(J J^T)) along the path (RK2 steps of `plan_dt`) and along the reconfiguration. The plan is refused (None) when its
smallest m is below `measure_floor` or its peak rate above beta'max: no path of the family (1) flies
the program within the limits, and the caller must say so before the slew.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

M_TARGET, MEASURE_FLOOR = 0.3, 0.05


@dataclass(slots=True)
class PlannedPath:
    """times (K+1,), angles (K+1, n) of the plan, its smallest sqrt(det J J^T) and peak rate [rad/s]."""

    times: np.ndarray
    angles: np.ndarray
    min_measure: float
    peak_rate: float

    def at(self, t: float) -> np.ndarray:
        """The planned angles at time t (linear between the plan's steps, held past its ends)."""
        return np.array([np.interp(t, self.times, column) for column in self.angles.T])


def null_vector(J: np.ndarray) -> np.ndarray:
    """n_i = (-1)^i det(J without column i) for a 3x4 J: J n = 0 and |n| = sqrt(det(J J^T))."""
    return np.array([(-1) ** i * np.linalg.det(np.delete(J, i, axis=1)) for i in range(J.shape[1])])


def _rates(jacobian, beta, hdot, c):
    J = jacobian(beta)
    n = null_vector(J)
    measure = float(np.linalg.norm(n))
    if measure < 1e-6:
        return None, measure
    return J.T @ np.linalg.solve(J @ J.T, hdot) + c * n / measure, measure


def integrate_path(jacobian, start, momentum_rate, duration: float, null_rates, plan_dt: float):
    """RK2 (midpoint) of eq. (1) with c(t) piecewise linear through `null_rates` over [0, duration]:
    (times, angles, measures, peak rate), cut where sqrt(det) < 1e-6 (then the measures end at 0)."""
    steps = max(1, int(round(duration / plan_dt)))
    times = np.linspace(0.0, duration, steps + 1)
    knots = np.linspace(0.0, duration, len(null_rates))
    c = lambda t: float(np.interp(t, knots, null_rates))  # noqa: E731
    dt = times[1] - times[0]
    angles, measures, peak = [np.array(start, float)], [], 0.0
    for t in times[:-1]:
        k1, m1 = _rates(jacobian, angles[-1], momentum_rate(t), c(t))
        if k1 is None:
            return times[:len(angles)], np.array(angles), np.array([*measures, 0.0]), np.inf
        mid = angles[-1] + 0.5 * dt * k1
        k2, m2 = _rates(jacobian, mid, momentum_rate(t + 0.5 * dt), c(t + 0.5 * dt))
        if k2 is None:
            return times[:len(angles)], np.array(angles), np.array([*measures, m1, 0.0]), np.inf
        measures += [m1, m2]
        peak = max(peak, float(np.abs(k1).max()), float(np.abs(k2).max()))
        angles.append(angles[-1] + dt * k2)
    measures.append(float(np.linalg.norm(null_vector(jacobian(angles[-1])))))
    return times, np.array(angles), np.array(measures), peak


def reconfigured(jacobian, start, offset: float) -> tuple[np.ndarray | None, np.ndarray]:
    """The start angles moved by `offset` [rad] of arc along their null-motion fibre (module doc),
    and sqrt(det(J J^T)) along the way (RK2 samples 0.025 rad apart); None for the angles when the
    integration stops at sqrt det < 1e-6. The plan refuses a way whose samples fall below its floor."""
    if offset == 0.0:
        return np.array(start, float), np.array([float(np.linalg.norm(null_vector(jacobian(start))))])
    steps = max(1, int(np.ceil(abs(offset) / 0.05)))  # RK2 steps of at most 0.05 rad
    times, angles, measures, _ = integrate_path(jacobian, start, lambda t: np.zeros(3), 1.0, [offset, offset],
                                                1.0 / steps)
    return (angles[-1] if times[-1] >= 1.0 - 1e-9 else None), measures


def plan_gimbal_path(jacobian, start, momentum_rate, duration: float, rate_max: float, *, knots: int = 4,
                     plan_dt: float = 0.5, m_target: float = M_TARGET, measure_floor: float = MEASURE_FLOOR,
                     offsets=np.linspace(-1.5, 1.5, 31), max_evaluations: int = 150) -> PlannedPath | None:
    """The plan of the module doc for the unit-h Jacobian `jacobian(beta)`, the start angles and the
    program's H_w'(t)/h (`momentum_rate(t)`, 3-vector) over [0, duration]; None when refused.
    The plan's first angles are the reconfigured start (PlannedPath.angles[0])."""
    def cost(values, full=False):
        first, on_the_way = reconfigured(jacobian, start, float(values[0]))
        if first is None:  # the reconfiguration meets a singular set
            return (np.zeros(1), np.array([start]), np.zeros(1), np.inf) if full else 1e3
        times, angles, measures, peak = integrate_path(jacobian, first, momentum_rate, duration, values[1:], plan_dt)
        measures = np.concatenate([on_the_way, measures])
        if full:
            return times, angles, measures, peak
        lost = duration - times[len(angles) - 1]  # time left after an integration cut at a singular set
        shortfall = np.maximum(0.0, m_target - measures) / m_target
        excess = max(0.0, peak / rate_max - 1.0) if np.isfinite(peak) else 10.0
        return (plan_dt * float(np.sum(shortfall ** 2)) / 2 + duration * excess ** 2 + 10.0 * lost
                + 1e-4 * float(np.sum((np.asarray(values) / rate_max) ** 2)))

    values = np.zeros(knots + 1)
    values[0] = min(offsets, key=lambda s: cost(np.concatenate([[s], values[1:]])))
    times, angles, measures, peak = cost(values, full=True)
    if not (measures.min() >= m_target and peak <= rate_max):
        found = minimize(cost, values, method="Powell",
                         options={"maxfev": max_evaluations, "xtol": 1e-3, "ftol": 1e-6})
        times, angles, measures, peak = cost(found.x, full=True)
    if times[-1] < duration * (1 - 1e-9) or measures.min() < measure_floor or peak > rate_max:
        return None
    return PlannedPath(times, angles, float(measures.min()), float(peak))

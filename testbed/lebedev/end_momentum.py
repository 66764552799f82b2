"""Whether the actuators can hold and turn the momentum a Lebedev spin-up ends with.

Our extension of Lebedev (1976) to a body whose actuators hold momentum H (docs/theory/lebedev.md "Non-zero
total momentum", "What the cluster cannot hold at the end spin"). The total momentum L = I w + H is fixed in
inertial space and keeps its length. At the wanted spin w = Omega e_z it makes an angle theta with
body z and turns in the body at -Omega about z, so the actuators must hold, for every phase phi,

    H(phi) = L(phi) - I Omega e_z = (|L| sin theta cos phi, |L| sin theta sin phi, |L| cos theta - Iz Omega)

(a horizontal circle of radius |L| sin theta), and turn it: Euler's equation of the bus at the goal
(w' = 0, no external torque) leaves the actuators H' = -w x H = -Omega e_z x H, a torque of size
Omega |L| sin theta along the circle. Both are asked of the plant's description through
`momentum_gauge(vectors) -> (gauge, u)` (gauge <= 1: the momentum can be held; the torques at
gimbal rates up to beta'max are beta'max times the same set, so no gimbal state gives a torque
whose gauge exceeds beta'max). A point of the circle with gauge > 1 is a momentum no actuator
state holds, a torque with gauge > beta'max one none gives: the spin-up cannot end there. `check_end_momentum_held` refuses an L for which that is so at every
angle theta the spin can end at: where the idle start-up leaves L (`idle_polar_angles` at the
start-up's end) give or take CLOSED_LOOP_TILT_DEG, the closed loop's tilt (docs/theory/lebedev.md); the most
favourable angle decides, so a refusal does not depend on where in that band the spin ends.
"""

from __future__ import annotations

import numpy as np

from testbed.errors import InputError
from testbed.lebedev.momentum import end_held_momentum, end_polar_band

# phases phi of the end circle, 2 deg apart: its largest demand is sampled to within
# 1 - cos(1 deg) = 1.5e-4, from below (a refusal stays certain)
CIRCLE_POINTS = 180
TIE_REL = 1e-9  # shares closer than this to the largest are a tie (a well-conditioned share moves ~1e-12)


def end_momentum_circle(moments, spin_rate, size: float, polar_deg: float, points: int = CIRCLE_POINTS):
    """(H, H') at `points` phases of the end spin with total momentum |L| = `size` [N m s] at
    `polar_deg` to body z (module doc): the momentum the actuators hold [N m s] and the torque
    H' = -Omega e_z x H they give [N m], body axes, each (points, 3)."""
    phase = np.linspace(0.0, 2.0 * np.pi, points, endpoint=False)
    held = end_held_momentum(moments, spin_rate, size, np.radians(polar_deg), phase)
    turned = -spin_rate * np.stack([-held[:, 1], held[:, 0], np.zeros_like(phase)], -1)
    return held, turned


def end_momentum_demand(gauge, moments, spin_rate, size: float, polars_deg, rate_limit=None):
    """The end circles' demands on the actuators, one per polar angle in `polars_deg`: a list of
    (share, vector, u, kind), share = max over phases of gauge(H) (kind "hold") and of
    gauge(H') / rate_limit (kind "turn", when a gimbal-rate limit [rad/s] is given), with the
    momentum or torque that sets it and the direction u of its gauge."""
    circles = [end_momentum_circle(moments, spin_rate, size, p) for p in polars_deg]
    demands = [("hold", np.stack([held for held, _ in circles]), 1.0)]
    if rate_limit:
        demands.append(("turn", np.stack([turned for _, turned in circles]), float(rate_limit)))
    worst = [None] * len(circles)
    for kind, vectors, limit in demands:   # (polars, phases, 3): one gauge call for all
        values, directions = gauge(vectors.reshape(-1, 3))
        with np.errstate(under="ignore"):   # a rate limit of 1e308 rad/s: the shares are 0, not an error
            values = values.reshape(vectors.shape[:2]) / limit
        directions = directions.reshape(vectors.shape)
        # the first phase within round-off of the largest share: the end circle is symmetric, and
        # which of two mirror phases comes out larger is the machine's round-off, not the physics
        near_max = values >= np.max(values, axis=1, keepdims=True) * (1.0 - TIE_REL)
        for i, k in enumerate(np.argmax(near_max, axis=1)):
            if worst[i] is None or values[i, k] > worst[i][0]:
                worst[i] = (float(values[i, k]), vectors[i, k], directions[i, k], kind)
    return worst


def check_end_momentum_held(gauge, moments, spin_rate, total_momentum, idle_end_polar_deg: float, field: str,
                            rate_limit=None) -> None:
    """Refuse a total momentum L (body axes, t = 0) whose end circle asks the actuators for more than
    they hold (or, with `rate_limit` beta'max [rad/s], turn) at every polar angle within
    CLOSED_LOOP_TILT_DEG of `idle_end_polar_deg` (module doc); `gauge` is the plant description's
    momentum_gauge."""
    L = np.asarray(total_momentum, float)
    size = float(np.linalg.norm(L))
    if size == 0.0:
        return
    polars = end_polar_band(idle_end_polar_deg, idle_end_polar_deg)
    demands = end_momentum_demand(gauge, moments, spin_rate, size, polars, rate_limit)
    best = min(range(len(polars)), key=lambda i: demands[i][0])   # the most favourable end angle
    (share, vector, u, kind), polar = demands[best], polars[best]
    if share <= 1.0:
        return
    if kind == "hold":
        need = f"to hold H = {_vector(vector)} N m s, {share:.3g} times what they can hold along u = {_vector(u, 3)}"
    else:
        need = (f"a torque H' = {_vector(vector, 3)} N m, {share:.3g} times what they give along u = "
                f"{_vector(u, 3)} at the gimbal-rate limit")
    raise InputError(field, f"total angular momentum L = {_vector(L, 2)} N m s: the actuators cannot keep the spin "
                            f"it ends in (at the wanted spin L turns in the body and they must hold L - I Omega e_z "
                            f"for every phase; at best, with L at {polar:.1f} deg to the spin axis, |L| = {size:.4g}, "
                            f"they need {need})")


def _vector(v, digits: int = 1) -> str:
    """(x, y, z) with `digits` decimals, no negative zeros."""
    return "(" + ", ".join(f"{x:.{digits}f}" for x in np.round(v, digits) + 0.0) + ")"

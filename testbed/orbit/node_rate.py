"""The J2 drift of the ascending node, measured on a sampled orbit and by its closed form
(docs/theory/environment.md, "Validation" 2 and `orbit_node_rate`)."""

from __future__ import annotations

import math

import numpy as np

from testbed.orbit.constants import EARTH_RADIUS_M, J2, MU_EARTH_M3_S2


def measured_node_rate(times, r, v) -> tuple[float, tuple[float, float, float]]:
    """(the node's rate [rad/s] between the first and the last ascending-node crossing, the
    mean elements (a [m], e, i [rad]) there) of states r [m], v [m/s] (N, 3) at `times` [s]:
    the node of h = r x v, atan2(h_x, -h_y), and each crossing (z rising through 0) interpolated
    linearly; the mean elements are the osculating ones (vis-viva, the eccentricity vector, h)
    averaged over the whole turns between the crossings. NaN with fewer than two crossings."""
    times, r, v = np.asarray(times, float), np.asarray(r, float), np.asarray(v, float)
    h = np.cross(r, v)
    node = np.unwrap(np.arctan2(h[:, 0], -h[:, 1]))
    z = r[:, 2]
    up = np.where((z[:-1] < 0) & (z[1:] >= 0))[0]
    if len(up) < 2:
        return float("nan"), (float("nan"),) * 3
    t_cross = times[up] - z[up] * (times[up + 1] - times[up]) / (z[up + 1] - z[up])
    node_cross = np.interp(t_cross, times, node)
    rate = (node_cross[-1] - node_cross[0]) / (t_cross[-1] - t_cross[0])
    within = (times >= t_cross[0]) & (times <= t_cross[-1])
    rn, vn = np.linalg.norm(r, axis=1), np.linalg.norm(v, axis=1)
    a = np.mean((1 / (2 / rn - vn**2 / MU_EARTH_M3_S2))[within])
    e = np.mean(np.linalg.norm(np.cross(v, h) / MU_EARTH_M3_S2 - r / rn[:, None], axis=1)[within])
    i = np.mean(np.arccos(h[:, 2] / np.linalg.norm(h, axis=1))[within])
    return float(rate), (float(a), float(e), float(i))


def first_order_node_rate(a: float, e: float, i: float) -> float:
    """dΩ/dt = -(3/2) n̄ J2 (R/p)² cos i [rad/s] of mean elements a [m], e, i [rad], with
    n̄ = n (1 + (3/4) J2 (R/p)² √(1 - e²) (2 - 3 sin² i)), the mean motion with its J2 term
    (Vallado, *Fundamentals of Astrodynamics*, eq. 9-41): exact to first order in J2 (R/p)²."""
    k = J2 * (EARTH_RADIUS_M / (a * (1 - e * e))) ** 2
    n_bar = math.sqrt(MU_EARTH_M3_S2 / a**3) * (1 + 0.75 * k * math.sqrt(1 - e * e) * (2 - 3 * math.sin(i) ** 2))
    return -1.5 * n_bar * k * math.cos(i)

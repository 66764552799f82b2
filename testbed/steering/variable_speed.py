"""Weighted steering of variable-speed gimballed wheels: gimbal rates and wheel accelerations.

A unit whose wheel speed may change gives two torques: gimbal mode D_i b'_i (D_i = Js_i W_i t_i,
t_i = dh_i/db_i / |h_i| the transverse axis) and wheel mode C_i W'_i (C_i = Js_i s_i, s_i the spin
axis). The cluster's momentum rate is then

    H' = D b' + C W' = Q eta,    Q = [C  D] (3 x 2N),   eta = (W', b')

and the weighted minimum-norm solution (Schaub, Vadali and Junkins 1998, "Feedback control
law for variable speed control moment gyros", eq. 29-31; Schaub and Junkins, Analytical
Mechanics of Space Systems, section 4.5)

    eta = W Q^T (Q W Q^T)^-1 H',    W = diag(Ws_1 .. Ws_N, Wg_1 .. Wg_N),
    Ws_i = Ws0_i exp(-mu delta),    delta = det(D D^T) / h^6

uses the wheels little while the gimbal part is well conditioned (delta large, Ws small) and
more as D nears a singular set (delta -> 0, Ws -> Ws0), where the gimbals alone cannot give
every torque: Q keeps rank 3 through the gimbals' singular sets. delta is the square of
sqrt(det(J J^T)) of the unit gimbal Jacobian when every h_i is h. Rate and acceleration limits
scale the whole solution (the demand's direction kept, as every law here: rate_limit.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(slots=True)
class VariableSpeedResult:
    """gimbal_rates b' [rad/s] and wheel_accelerations W' [rad/s^2] (N,) each; hdot_delivered
    Q eta (3,) [N m]; scale k in (0, 1] the limits applied; gimbal_measure sqrt(delta);
    wheel_weight Ws_i / Ws0_i = exp(-mu delta)."""

    gimbal_rates: np.ndarray
    wheel_accelerations: np.ndarray
    hdot_delivered: np.ndarray
    scale: float
    gimbal_measure: float
    wheel_weight: float


def variable_speed_steering(gimbal_columns, wheel_columns, hdot, h, *, gimbal_weight=1.0, wheel_weight=2.0,
                            decay=1e9, beta_rate_max=np.inf, wheel_acceleration_bounds=None) -> VariableSpeedResult:
    """eta = W Q^T (Q W Q^T)^-1 H' of the module doc, then scaled into the limits.

    gimbal_columns D (3, N) [N m s / rad], wheel_columns C (3, N) [kg m^2], hdot (3,) [N m],
    h the nominal wheel momentum [N m s] (delta's scale); gimbal_weight Wg, wheel_weight Ws0,
    decay mu; wheel_acceleration_bounds (lo, hi) (N,) each [rad/s^2], holding 0 (the speed
    range as bounds over the coming control period)."""
    d = np.asarray(gimbal_columns, float)
    c = np.asarray(wheel_columns, float)
    n = d.shape[1]
    delta = float(np.linalg.det(d @ d.T)) / h**6
    ws = wheel_weight * np.exp(-decay * max(delta, 0.0))
    weights = np.concatenate([np.full(n, ws), np.full(n, float(gimbal_weight))])
    q = np.hstack([c, d])
    qw = q * weights
    eta = qw.T @ np.linalg.solve(qw @ q.T, np.asarray(hdot, float))
    wheel, gimbal = eta[:n], eta[n:]
    scale = 1.0
    peak = float(np.max(np.abs(gimbal)))
    if peak > beta_rate_max:
        scale = beta_rate_max / peak
    if wheel_acceleration_bounds is not None:
        lo, hi = (np.asarray(b, float) for b in wheel_acceleration_bounds)
        for value, low, high in zip(wheel, lo, hi):
            if value > high:
                scale = min(scale, high / value)
            elif value < low:
                scale = min(scale, low / value)
    wheel, gimbal = scale * wheel, scale * gimbal
    return VariableSpeedResult(gimbal, wheel, c @ wheel + d @ gimbal, scale, float(np.sqrt(max(delta, 0.0))),
                               float(ws / wheel_weight) if wheel_weight > 0 else 0.0)

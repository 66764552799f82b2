"""What float32 arithmetic does to a spacecraft run's clock, attitude and momentum: the figures of
docs/theory/gpu-backend.md, computed with NumPy in float32 and float64 side by side (no GPU).

1. The clock: t advanced by t += dt in float32, as a physics state held in float32 keeps it,
   against k dt in float64; and the spacing of float32 numbers at the run's end.
2. A torque-free rigid body with the flagship's inertia (Euler's equations and the quaternion
   kinematics, classical RK4 at dt, the quaternion renormalised after each step as MuJoCo's
   integrator does), N worlds at once with random initial rates of about 1 deg/s. In each
   precision: the relative drift of the world-frame angular momentum |H(t) - H(0)| / |H(0)|
   (exactly conserved by the equations, so what is left is round-off and RK4's truncation),
   the attitude's angle from the float64 run; the same with the rates in float32 and the
   attitude in float64; and, without the renormalisation, how far |q| strays from 1.

    .venv/bin/python bench/float32_drift.py [--duration 600] [--dt 0.01] [--worlds 64]
"""

from __future__ import annotations

import argparse

import numpy as np

INERTIA = np.array([1250.0, 6900.0, 7100.0])  # [kg m^2], the flagship's locked inertia (principal axes)


def clock(duration: float, dt: float) -> tuple[float, float, float]:
    """(float32 clock's error at the end [s], float32 spacing there [s], float64 clock's error [s]),
    each clock advanced by t += dt from 0 and compared with n dt."""
    n = round(duration / dt)
    t32, step32, t64 = np.float32(0.0), np.float32(dt), 0.0
    for _ in range(n):
        t32, t64 = t32 + step32, t64 + dt
    return float(t32) - n * dt, float(np.spacing(np.float32(duration))), t64 - n * dt


def quat_times_rate(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """q (x) (0, w) / 2, rows of q (N, 4) (w, x, y, z) and body rates w (N, 3) [rad/s]: q's rate."""
    q0, qv = q[:, :1], q[:, 1:]
    return np.concatenate([-(qv * w).sum(axis=1, keepdims=True), q0 * w + np.cross(qv, w)], axis=1) / 2


def derivative(q: np.ndarray, w: np.ndarray, inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(dq/dt, dw/dt) of a torque-free rigid body: Euler's equations I w' = -w x I w."""
    return quat_times_rate(q, w), -np.cross(w, w * inertia) / inertia


def angle_between(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The rotation angle [rad] from attitude p to attitude q, rows (N, 4): 2 atan2(|v|, |w|) of
    conj(p) (x) q / |q| (atan2, not arccos of the dot product, which loses small angles)."""
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    p0, pv, q0, qv = p[:, 0], -p[:, 1:], q[:, 0], q[:, 1:]
    w = p0 * q0 - (pv * qv).sum(axis=1)
    v = p0[:, None] * qv + q0[:, None] * pv + np.cross(pv, qv)
    return 2 * np.arctan2(np.linalg.norm(v, axis=1), np.abs(w))


def world_momentum(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """H = R(q) I w in float64 [N m s], rows (N, 3)."""
    q, h = q.astype(float), w.astype(float) * INERTIA
    q0, qv = q[:, :1], q[:, 1:]
    return h + 2 * q0 * np.cross(qv, h) + 2 * np.cross(qv, np.cross(qv, h))


def rigid_body(w0: np.ndarray, duration: float, dt: float, rates, attitude=None, renormalise: bool = True):
    """(q, w) after `duration` [s] of RK4 steps of `dt` [s] from the identity attitude, the rates w
    held and integrated in the dtype `rates`, the attitude q in `attitude` (default: `rates`)."""
    attitude = attitude or rates
    inertia, h, half, sixth = INERTIA.astype(rates), rates(dt), rates(dt / 2), rates(dt / 6)
    hq, halfq, sixthq = attitude(dt), attitude(dt / 2), attitude(dt / 6)
    w = w0.astype(rates)
    q = np.zeros((len(w0), 4), dtype=attitude)
    q[:, 0] = 1
    for _ in range(round(duration / dt)):
        k1q, k1w = derivative(q, w, inertia)
        k2q, k2w = derivative(q + halfq * k1q, w + half * k1w, inertia)
        k3q, k3w = derivative(q + halfq * k2q, w + half * k2w, inertia)
        k4q, k4w = derivative(q + hq * k3q, w + h * k3w, inertia)
        q = (q + sixthq * (k1q + 2 * k2q + 2 * k3q + k4q)).astype(attitude)
        w = w + sixth * (k1w + 2 * k2w + 2 * k3w + k4w)
        if renormalise:
            q = q / np.sqrt((q * q).sum(axis=1, keepdims=True))
    return q, w


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--duration", type=float, default=600.0, help="[s] simulated")
    parser.add_argument("--dt", type=float, default=0.01, help="[s] step")
    parser.add_argument("--worlds", type=int, default=64)
    args = parser.parse_args()
    n = round(args.duration / args.dt)

    error, spacing, error64 = clock(args.duration, args.dt)
    print(f"clock, {n} steps of {args.dt:g} s: t - n dt at {args.duration:g} s = {error:.3g} s in float32, "
          f"{error64:.3g} s in float64; float32 spacing at {args.duration:g} s = {spacing:.3g} s; "
          f"float32 unit round-off {np.finfo(np.float32).eps / 2:.3g}, epsilon {np.finfo(np.float32).eps:.3g}")

    rng = np.random.default_rng(1976)
    w0 = rng.normal(size=(args.worlds, 3))
    w0 *= np.radians(1.0) / np.linalg.norm(w0, axis=1, keepdims=True)  # 1 deg/s, random axes
    w0 = w0.astype(np.float32).astype(float)  # both precisions start from the same numbers
    q64, w64 = rigid_body(w0, args.duration, args.dt, np.float64)
    h0 = world_momentum(np.tile([1.0, 0, 0, 0], (args.worlds, 1)), w0)
    size = np.linalg.norm(h0, axis=1)
    print(f"torque-free rigid body, {args.worlds} worlds, |w| = 1 deg/s, RK4, {n} steps:")
    for name, rates, attitude in (("float64", np.float64, np.float64), ("float32", np.float32, np.float32),
                                  ("float32 rates, float64 attitude", np.float32, np.float64)):
        q, w = (q64, w64) if rates is np.float64 else rigid_body(w0, args.duration, args.dt, rates, attitude)
        drift = np.linalg.norm(world_momentum(q, w) - h0, axis=1) / size
        angle = angle_between(q64, q.astype(float))
        away = (f"attitude from float64 median {np.median(angle):.3g} rad, max {angle.max():.3g} rad"
                if rates is np.float32 else "the reference attitude")
        print(f"  {name}: momentum drift rel median {np.median(drift):.3g}, max {drift.max():.3g}; {away}",
              flush=True)
    q, _ = rigid_body(w0, args.duration, args.dt, np.float32, renormalise=False)
    norm = np.abs(np.linalg.norm(q.astype(float), axis=1) - 1)
    print(f"  float32 without renormalising q: ||q| - 1| median {np.median(norm):.3g}, max {norm.max():.3g}")

if __name__ == "__main__":
    main()

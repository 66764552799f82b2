"""Where one gyro stops observing a spinning CMG spacecraft with stored momentum (README table).

    .venv/bin/python bench/lebedev_momentum_boundary.py [--inertia 1250,6900,7100] [--spin-deg-s 1]

For the flagship's spacecraft (locked inertia, the paper's gyro axis, Omega = 1 deg/s) prints the
three axial total momenta that are unobservable, the radius r* of the ball of total momenta whose
every state is observable, and the least observability margin det W(L) / det W(0) over the end
states of a spin with total momentum |L| at angle theta to the spin axis
(testbed.observers.lebedev_momentum.end_state_margin with no band: the circle itself); the
load-time check refuses margins below MIN_MARGIN within END_BAND_DEG of the initial angle.
"""

from __future__ import annotations

import argparse

import numpy as np

from testbed.observers.lebedev_momentum import (
    MIN_MARGIN,
    axial_unobservable_momenta,
    end_state_margin,
    observable_momentum_radius,
)

SIZES = (10, 20, 40, 65, 100)
ANGLES_DEG = (0, 30, 60, 90, 120, 150, 180)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--inertia", default="1250,6900,7100")
    parser.add_argument("--spin-deg-s", type=float, default=1.0)
    parser.add_argument("--axis", default="1,1,1")
    args = parser.parse_args()
    inertia = np.array([float(v) for v in args.inertia.split(",")])
    axis = np.array([float(v) for v in args.axis.split(",")])
    axis /= np.linalg.norm(axis)
    spin = np.radians(args.spin_deg_s)
    radius, nearest = observable_momentum_radius(inertia, spin, axis)
    print(f"inertia {inertia.tolist()} kg m^2, Omega {args.spin_deg_s} deg/s, gyro axis {np.round(axis, 4).tolist()}")
    print("axial unobservable L3 [N m s]:", np.round(axial_unobservable_momenta(inertia, spin, axis), 2).tolist())
    print(f"r* = {radius:.2f} N m s (nearest unobservable L = {np.round(nearest, 2).tolist()})")
    print("| L [N m s] | " + " | ".join(f"{a} deg" for a in ANGLES_DEG) + " |")
    print("|---:|" + "---:|" * len(ANGLES_DEG))
    for size in SIZES:
        cells = []
        for angle in np.radians(ANGLES_DEG):
            L = size * np.array([np.sin(angle), 0.0, np.cos(angle)])
            margin, _ = end_state_margin(inertia, spin, axis, L, band_deg=0.0)
            cells.append(f"{margin:.2g}" + ("" if margin >= MIN_MARGIN else " x"))
        print(f"| {size} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()

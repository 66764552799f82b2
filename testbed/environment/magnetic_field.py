"""The geomagnetic field from the International Geomagnetic Reference Field (IGRF-14, the
`ppigrf` package and the coefficient file its wheel ships): the full model to degree 13 with
its secular variation, or its first degree alone (a tilted dipole, `model: dipole`), at ITRS
positions; both on IGRF's reference sphere of 6371.2 km (docs/theory/environment.md)."""

from __future__ import annotations

import datetime

import numpy as np

IGRF_SPAN_YEARS = (1900, 2030)   # IGRF-14: definitive and provisional models, secular variation to 2030
DEGREES = {"igrf": 13, "dipole": 1}


def field_itrs(r_itrs, when: np.datetime64, model: str = "igrf") -> np.ndarray:
    """B [T], (N, 3), ITRS axes, at ITRS positions r_itrs (N, 3) [m], of the IGRF coefficients
    at the UTC instant `when` (to degree 13, or 1 for the dipole): ppigrf's geocentric
    (B_r, B_theta, B_phi) turned into Cartesian axes."""
    import ppigrf  # here: it brings pandas (0.7 s), which only a run with a field needs

    r = np.atleast_2d(np.asarray(r_itrs, float))
    radius = np.linalg.norm(r, axis=1)
    colatitude = np.arccos(r[:, 2] / radius)
    longitude = np.arctan2(r[:, 1], r[:, 0])
    moment = datetime.datetime.fromisoformat(str(np.datetime64(when, "us")))
    radial, south, east = (np.asarray(b, float).reshape(-1) * 1e-9 for b in ppigrf.igrf_gc(
        radius / 1e3, np.degrees(colatitude), np.degrees(longitude), moment, max_degree=DEGREES[model]))
    ct, st, cp, sp = np.cos(colatitude), np.sin(colatitude), np.cos(longitude), np.sin(longitude)
    up = np.column_stack([st * cp, st * sp, ct])
    theta_hat = np.column_stack([ct * cp, ct * sp, -st])
    phi_hat = np.column_stack([-sp, cp, np.zeros_like(cp)])
    return radial[:, None] * up + south[:, None] * theta_hat + east[:, None] * phi_hat

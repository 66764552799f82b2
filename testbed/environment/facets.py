"""Flat-plate facet models of the bus's surface for drag and solar pressure (the facet
models of Basilisk's facetDragDynamicEffector and facetSRPDynamicEffector; Wertz,
*Spacecraft Attitude Determination and Control*, eq. 17-14 and 17-12): each facet has an
area A, an outward normal n and a centre of pressure c relative to the centre of mass."""

from __future__ import annotations

import numpy as np


class Facets:
    """The six faces of a box of half sizes (a, b, c) [m], each face's centre shifted by
    `offset` [m] (the centre of pressure's offset from the CoM), body axes."""

    def __init__(self, half_size, offset):
        a, b, c = map(float, half_size)
        eye = np.eye(3)
        self.normals = np.concatenate([eye, -eye])
        area = np.array([4 * b * c, 4 * a * c, 4 * a * b])
        self.areas = np.concatenate([area, area])
        self.centres = self.normals * np.concatenate([[a, b, c], [a, b, c]])[:, None] + np.asarray(offset, float)

    def drag_torque(self, v_body, density: float, drag_coefficient: float) -> np.ndarray:
        """Sum over facets facing the flow of c x F, F = -1/2 rho Cd A |v|^2 max(0, n . v_hat) v_hat
        (v_body: the velocity relative to the atmosphere, body axes [m/s]) [N m]."""
        speed = float(np.linalg.norm(v_body))
        if speed == 0.0 or density == 0.0:
            return np.zeros(3)
        u = np.asarray(v_body, float) / speed
        projected = np.maximum(self.normals @ u, 0.0) * self.areas
        forces = -0.5 * density * drag_coefficient * speed**2 * projected[:, None] * u
        return np.cross(self.centres, forces).sum(axis=0)

    def solar_pressure_torque(self, sun_body, pressure: float, specular: float, diffuse: float) -> np.ndarray:
        """Sum over lit facets of c x F, F = -P A cos(t) ((1 - rho_s) s + 2 (rho_s cos(t) + rho_d / 3) n),
        cos(t) = n . s > 0 (s: the unit direction to the Sun, body axes; P [N/m^2]) [N m]."""
        s = np.asarray(sun_body, float)
        cosines = self.normals @ s
        lit = cosines > 0.0
        c = cosines[lit][:, None]
        forces = -pressure * self.areas[lit][:, None] * c * (
            (1.0 - specular) * s + 2.0 * (specular * c + diffuse / 3.0) * self.normals[lit])
        return np.cross(self.centres[lit], forces).sum(axis=0)

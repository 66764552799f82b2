"""Closed-form modes of a bus with hinged panels (planar: every hinge axis along one principal
axis of the rigid part, every CoM in one plane normal to it; free-free and clamped) and of the
slosh models (spring-mass on the free bus in 3D; pendulum under thrust). The derivations, eq.
F1-F8, are in docs/theory/flexible.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.appendages.build import SPRING_MASS_SIZE_M
from testbed.appendages.params import SloshParams, WingParams

PLANAR_TOLERANCE = 1e-9  # relative: how far from planar a configuration may be for these forms to hold


@dataclass(frozen=True)
class RigidPart:
    """The rigid spacecraft the wings hang on: mass [kg], CoM [m] and inertia about it [kg m^2], bus axes."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class Modes:
    """Natural frequencies [rad/s] and damping ratios of the elastic modes, lowest first."""

    frequency: np.ndarray
    damping_ratio: np.ndarray


def _modes(mass, stiffness, damping) -> Modes:
    """The elastic modes of M q'' + C q' + K q = 0: the eigenvalues s of the first-order system
    with Im s > 0 (and the overdamped ones, real and negative), w_n = |s|, zeta = -Re s / |s|;
    the rigid modes (s = 0) dropped."""
    n = len(mass)
    solve = np.linalg.solve(mass, np.hstack([stiffness, damping]))
    system = np.block([[np.zeros((n, n)), np.eye(n)], [-solve[:, :n], -solve[:, n:]]])
    s = np.linalg.eigvals(system)
    scale = np.sqrt(np.max(np.abs(np.linalg.eigvals(np.linalg.solve(mass, stiffness)))))
    elastic = s[(np.abs(s) > 1e-7 * scale) & (s.imag >= -1e-12 * scale)]
    elastic = elastic[np.argsort(np.abs(elastic))]
    return Modes(np.abs(elastic), -elastic.real / np.abs(elastic))


def planar_parts(rigid: RigidPart, wings: list[WingParams]):
    """(masses (B,), levers (B, 3, n), inertias about the axis (B,), K, C) of the planar model
    about the common hinge axis (module doc), bodies (the rigid part, each panel wing by wing,
    root first), coordinates their absolute angles in the same order; raises ValueError when the
    configuration is not planar (hinge axes not parallel, the axis not principal for the rigid
    part, CoMs off one plane)."""
    axis = np.asarray(wings[0].hinge_axis, float)
    for wing in wings:
        if np.linalg.norm(np.cross(wing.hinge_axis, axis)) > PLANAR_TOLERANCE:
            raise ValueError("the wings' hinge axes are not parallel")
    torque = rigid.inertia @ axis
    if np.linalg.norm(torque - (axis @ torque) * axis) > PLANAR_TOLERANCE * np.linalg.norm(torque):
        raise ValueError("the hinge axis is not a principal axis of the rigid part")
    panels = [(wing, p, panel) for wing in wings for p, panel in enumerate(wing.panels)]
    n = 1 + len(panels)
    masses, levers, inertias = [rigid.mass], [np.zeros((3, n))], [axis @ rigid.inertia @ axis]
    levers[0][:, 0] = np.cross(axis, rigid.com)
    heights = [axis @ rigid.com]
    column = 1
    for wing in wings:
        span = np.asarray(wing.span_axis, float)
        path = [np.cross(axis, wing.hinge_position_m)]  # bus -> root hinge, then hinge -> hinge
        columns = [0]
        for panel in wing.panels:
            lever = np.zeros((3, n))
            for c, arm in zip(columns, path):
                lever[:, c] = arm
            lever[:, column] = np.cross(axis, panel.offset() * span)
            masses.append(panel.mass_kg)
            levers.append(lever)
            inertias.append(panel.inertia()[1])
            heights.append(axis @ (np.asarray(wing.hinge_position_m, float)))
            path.append(np.cross(axis, panel.length_m * span))
            columns.append(column)
            column += 1
    size = max(np.max(np.abs(heights)), max(np.linalg.norm(lever) for lever in levers), 1.0)
    if np.ptp(heights) > PLANAR_TOLERANCE * size:
        raise ValueError("the CoMs do not lie in one plane normal to the hinge axis")
    stiffness, damping = np.zeros((n, n)), np.zeros((n, n))
    column = 1
    for wing in wings:
        parent = 0
        for panel in wing.panels:
            relative = np.zeros(n)
            relative[column], relative[parent] = 1.0, -1.0
            stiffness += panel.stiffness_nm_rad * np.outer(relative, relative)
            damping += panel.damping_nms_rad * np.outer(relative, relative)
            parent, column = column, column + 1
    return np.array(masses), np.array(levers), np.array(inertias), stiffness, damping


def free_free_modes(rigid: RigidPart, wings: list[WingParams]) -> Modes:
    """The elastic modes of the free spacecraft in the hinge plane: M of the module doc
    (docs/theory/flexible.md, eq. F3), the translation eliminated by the fixed CoM."""
    masses, levers, inertias, stiffness, damping = planar_parts(rigid, wings)
    momentum = np.einsum("b,bij->ij", masses, levers)
    mass = np.diag(inertias) + np.einsum("b,bki,bkj->ij", masses, levers, levers) - momentum.T @ momentum / masses.sum()
    return _modes(mass, stiffness, damping)


def clamped_modes(rigid: RigidPart, wings: list[WingParams]) -> Modes:
    """The modes of the panels with the bus held still (theta_0 = 0, no translation): the panels'
    own kinetic energy, each CoM moved by the hinges inboard of it (eq. F6)."""
    masses, levers, inertias, stiffness, damping = planar_parts(rigid, wings)
    panels = levers[1:, :, 1:]
    mass = np.diag(inertias[1:]) + np.einsum("b,bki,bkj->ij", masses[1:], panels, panels)
    return _modes(mass, stiffness[1:, 1:], damping[1:, 1:])


def _cross_matrix(v) -> np.ndarray:
    """[v]x: [v]x w = v x w."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def spring_mass_modes(rigid: RigidPart, slosh: list[SloshParams]) -> Modes:
    """The elastic modes of spring-mass slosh models on the free rigid bus, in 3D (eq. F7): the
    coordinates are the bus's small rotation phi (3) and each slide's offset, the translation
    eliminated by the fixed CoM; each mass is a cube (build.py) that turns with the bus."""
    n = 3 + sum(len(s.slide_axes) for s in slosh)
    rotation = np.zeros((n, n))
    rotation[:3, :3] = rigid.inertia
    masses, levers = [rigid.mass], [np.hstack([-_cross_matrix(rigid.com), np.zeros((3, n - 3))])]
    stiffness, damping = np.zeros((n, n)), np.zeros((n, n))
    column = 3
    for model in slosh:
        lever = np.zeros((3, n))
        lever[:, :3] = -_cross_matrix(model.position_m)
        rotation[:3, :3] += np.eye(3) * 2.0 / 3.0 * model.mass_kg * SPRING_MASS_SIZE_M ** 2
        for axis in model.slide_axes:
            lever[:, column] = axis
            stiffness[column, column], damping[column, column] = model.stiffness(), model.slide_damping()
            column += 1
        masses.append(model.mass_kg)
        levers.append(lever)
    masses, levers = np.array(masses), np.array(levers)
    momentum = np.einsum("b,bij->ij", masses, levers)
    mass = rotation + np.einsum("b,bki,bkj->ij", masses, levers, levers) - momentum.T @ momentum / masses.sum()
    return _modes(mass, stiffness, damping)


def two_body_frequency(rigid_inertia: float, rigid_mass: float, hinge_lever, panel_inertia: float,
                       panel_mass: float, panel_lever, stiffness: float) -> float:
    """Free-free frequency [rad/s] of two bodies pinned at a hinge with torsional spring k [N m/rad]:
    w^2 = k (M11 + M22 + 2 M12) / det M, M11 = I1 + mu |a|^2, M22 = I2 + mu |b|^2, M12 = -mu a.b,
    mu = m1 m2 / (m1 + m2), a and b the in-plane vectors from each CoM to the hinge [m]
    (docs/theory/flexible.md, eq. F5)."""
    a, b = np.asarray(hinge_lever, float), np.asarray(panel_lever, float)
    mu = rigid_mass * panel_mass / (rigid_mass + panel_mass)
    m11, m22, m12 = rigid_inertia + mu * a @ a, panel_inertia + mu * b @ b, -mu * a @ b
    return float(np.sqrt(stiffness * (m11 + m22 + 2.0 * m12) / (m11 * m22 - m12 * m12)))


def pendulum_frequency(acceleration: float, length: float, bob_inertia: float, mass: float) -> float:
    """A pendulum's small-swing frequency [rad/s] under a steady acceleration g [m/s^2] with the
    pivot held: w^2 = m g L / (m L^2 + I_bob), sqrt(g / L) for a point bob."""
    return float(np.sqrt(mass * acceleration * length / (mass * length ** 2 + bob_inertia)))

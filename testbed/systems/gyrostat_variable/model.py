"""Variable-structure gyrostat (Bezglasny & Khudyakova, seed 002): models/gyrostat_variable.xml.

Carrier T1 (a solid cylinder plus a thin rod turning about the common centre of mass O) on a
free joint, and a coaxial rotor T2 (solid elliptic cylinder) turning about the carrier's z
axis. Both internal motions are prescribed, alpha(t) = rod_rate t and sigma(t) = rotor_rate t
(paper: 0.1 t and t), and followed by stiff PD servos (an <intvelocity> plus a <velocity>
actuator per hinge, see models/gyrostat_variable.xml).

Placement (paper, section "Постановка задачи": O1 O = l1, O2 O = l2, m1 l1 = m2 l2): the
rod's centre is hinged at O, so T1's mass is cylinder + rod and the cylinder's centre must
sit at d = m2 l2 / m_cyl below O for O to be the common centre of mass; T1's own centre of
mass is then at l1 = m2 l2 / (m_cyl + m_rod) = 0.3 m in the worked example (500 * 0.3 =
300 * 0.5). The paper's I1x = 210 is 165 + (m_cyl + m_rod) l1^2, i.e. it treats the rod as
if it sat at T1's centre of mass; the model's exact value about O is 165 + 495 d^2 = 210.4545
(+0.22 %). See `inertia_about_point` and tests/test_gyrostat_variable.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.systems.free_bus import BUS_BODY
from testbed.math.euler_angles import wrap_angle
from testbed.scenario.shipped_files import compile_model, load_spec
from testbed.scenario.schema import join, param

XML_FILE = "gyrostat_variable.xml"

# MuJoCo refuses a zero principal moment on a moving body; the thin rod's axial moment
# (exactly zero in the paper) is floored here, 1e-8 of its transverse moment.
ROD_AXIAL_FLOOR_KG_M2 = 1e-9

ACTUATORS = ("rod_angle", "rod_rate", "rotor_angle", "rotor_rate")


@dataclass
class VariableGyrostatParams:
    system: str = "gyrostat_variable"
    carrier_mass_kg: float = param(495.0, gt=0, doc="solid circular cylinder, T1 without the rod")
    carrier_radius_m: float = param(1.0, gt=0)
    carrier_height_m: float = param(1.0, gt=0)
    rod_mass_kg: float = param(5.0, gt=0, doc="thin rod, centre hinged at O")
    rod_length_m: float = param(0.5, gt=0)
    rotor_mass_kg: float = param(300.0, gt=0, doc="solid elliptic cylinder T2")
    rotor_height_m: float = param(0.5, gt=0)
    rotor_semi_axis_x_m: float = param(0.8, gt=0)
    rotor_semi_axis_y_m: float = param(1.0, gt=0)
    rotor_offset_m: float = param(0.5, gt=0, doc="l2 = O2 O")
    rod_rate_rad_s: float = param(0.1, doc="alpha(t) = rod_rate t, from the carrier's z axis")
    rotor_rate_rad_s: float = param(1.0, doc="sigma(t) = rotor_rate t")
    servo_bandwidth_rad_s: float = param(50.0, gt=0, doc="natural frequency of the hinge servos")
    servo_damping_ratio: float = param(1.0, gt=0)
    # the experiment of section 4: the program r(t) = r0 + r1 t and the initial deviations
    program_angles_deg: list[float] = param([0.0, 30.0, 45.0], length=3,
                                            doc="r(0) = (phi*, psi*, theta*) at t = 0 (z-x-z Euler angles)")
    program_rates_rad_s: list[float] = param([1.0, 0.0, 0.0], length=3, doc="r' (constant): phi* = t")
    initial_deviation_rad: list[float] = param([0.004, 0.005, 0.005], length=3, doc="x(0) = q(0) - r(0)")
    initial_deviation_rate_rad_s: list[float] = param([0.002, 0.003, 0.003], length=3, doc="x'(0)")

    def validate(self, path: str) -> None:
        theta = np.radians(self.program_angles_deg[2]) + self.initial_deviation_rad[2]
        if abs(np.sin(theta)) < 1e-3:
            raise InputError(join(path, "program_angles_deg"), "theta must start away from 0 and 180 deg "
                             "(the z-x-z Euler angles are singular at sin theta = 0)")


def cylinder_inertia(mass: float, radius: float, height: float) -> np.ndarray:
    """Central principal moments of a solid circular cylinder, axis z: m(3R^2+h^2)/12, mR^2/2."""
    transverse = mass * (3 * radius**2 + height**2) / 12
    return np.array([transverse, transverse, mass * radius**2 / 2])


def elliptic_cylinder_inertia(mass: float, a: float, b: float, height: float) -> np.ndarray:
    """Central principal moments of a solid elliptic cylinder, semi-axes a (x), b (y), axis z.

    Ixx = m (b^2/4 + h^2/12), Iyy = m (a^2/4 + h^2/12), Izz = m (a^2 + b^2)/4.
    """
    return mass * np.array([b**2 / 4 + height**2 / 12, a**2 / 4 + height**2 / 12, (a**2 + b**2) / 4])


def thin_rod_inertia(mass: float, length: float) -> np.ndarray:
    """Central principal moments of a thin rod along its own z: (m l^2/12, m l^2/12, ~0)."""
    transverse = mass * length**2 / 12
    return np.array([transverse, transverse, ROD_AXIAL_FLOOR_KG_M2])


def cylinder_offset(params: VariableGyrostatParams) -> float:
    """Distance d of the carrier cylinder's centre below O that makes O the common CoM.

    m_cyl d = m2 l2 (the rod's centre is at O and adds no moment).
    """
    return params.rotor_mass_kg * params.rotor_offset_m / params.carrier_mass_kg


def carrier_com_offset(params: VariableGyrostatParams) -> float:
    """l1 = O1 O: T1's (cylinder + rod) centre of mass, m2 l2 / (m_cyl + m_rod) (paper: 0.3 m)."""
    return params.rotor_mass_kg * params.rotor_offset_m / (params.carrier_mass_kg + params.rod_mass_kg)


def build(params: VariableGyrostatParams, dt: float = 1e-3, integrator: str = "RK4") -> mujoco.MjModel:
    """Compile models/gyrostat_variable.xml with the shapes' inertials and servo gains applied."""
    spec = load_spec(XML_FILE, dt, integrator)

    d = cylinder_offset(params)
    carrier = spec.body(BUS_BODY)
    carrier.mass = params.carrier_mass_kg
    carrier.ipos = [0.0, 0.0, -d]
    carrier.inertia = cylinder_inertia(params.carrier_mass_kg, params.carrier_radius_m, params.carrier_height_m)
    cyl = spec.geom("carrier_cylinder")
    cyl.pos = [0.0, 0.0, -d]
    cyl.size = [params.carrier_radius_m, params.carrier_height_m / 2, 0.0]

    rod_inertia = thin_rod_inertia(params.rod_mass_kg, params.rod_length_m)
    rod = spec.body("rod")
    rod.mass = params.rod_mass_kg
    rod.inertia = rod_inertia
    spec.geom("rod_geom").fromto = [0, 0, -params.rod_length_m / 2, 0, 0, params.rod_length_m / 2]

    rotor_inertia = elliptic_cylinder_inertia(params.rotor_mass_kg, params.rotor_semi_axis_x_m,
                                              params.rotor_semi_axis_y_m, params.rotor_height_m)
    rotor = spec.body("rotor")
    rotor.pos = [0.0, 0.0, params.rotor_offset_m]
    rotor.mass = params.rotor_mass_kg
    rotor.inertia = rotor_inertia
    spec.geom("rotor_geom").size = [params.rotor_semi_axis_x_m, params.rotor_semi_axis_y_m,
                                    params.rotor_height_m / 2]

    # PD gains from the hinge's own axial inertia: kp = I wn^2, kv = 2 zeta I wn. The
    # effective inertia with the free carrier is smaller (rotor: 123 -> ~82 kg m^2), which
    # only raises wn by ~20 %; keep wn dt well below 1 for RK4.
    wn, zeta = params.servo_bandwidth_rad_s, params.servo_damping_ratio
    if wn * dt > 0.5:
        raise InputError("model.servo_bandwidth_rad_s",
                         f"servo bandwidth x time step = {wn * dt:g} must stay below 0.5 for RK4")
    for name, inertia in (("rod", rod_inertia[1]), ("rotor", rotor_inertia[2])):
        spec.actuator(f"{name}_angle").set_to_intvelocity(kp=inertia * wn**2, kv=0.0)
        spec.actuator(f"{name}_angle").actrange = [-1e9, 1e9]
        spec.actuator(f"{name}_rate").set_to_velocity(kv=2 * zeta * inertia * wn)
    return compile_model(spec)


def prescribed(t: float, params: VariableGyrostatParams) -> dict[str, float]:
    """The prescribed internal motion at time t: angles alpha, sigma and their rates."""
    return {"rod_angle": params.rod_rate_rad_s * t, "rod_rate": params.rod_rate_rad_s,
            "rotor_angle": params.rotor_rate_rad_s * t, "rotor_rate": params.rotor_rate_rad_s}


def program(params: VariableGyrostatParams, t):
    """r(t), r'(t), r''(t) of the linear program r0 + r1 t (arrays broadcast over t)."""
    t = np.asarray(t, float)
    r0, r1 = np.radians(params.program_angles_deg), np.asarray(params.program_rates_rad_s, float)
    return r0 + np.multiply.outer(t, r1), np.broadcast_to(r1, t.shape + (3,)), np.zeros(t.shape + (3,))


def deviations(params: VariableGyrostatParams, t, q, qd):
    """x = q - r(t) (wrapped to [-pi, pi]) and x' = q' - r'(t): the deviations from the program
    (Bezglasny & Khudyakova, section 3); one state or histories (t of shape (N,), q, q' (N, 3))."""
    r, rd, _ = program(params, t)
    return wrap_angle(q - r), qd - rd


def inertia_about_point(model: mujoco.MjModel, data: mujoco.MjData, bodies, frame_body: str,
                        point=None) -> np.ndarray:
    """Inertia tensor of `bodies` about `point` (world; default: frame_body's origin), in the
    axes of `frame_body`, from the compiled inertials and the current kinematics.

    I = sum_b R_b diag(body_inertia_b) R_b^T + m_b (|r_b|^2 E - r_b r_b^T) (Huygens-Steiner),
    with R_b the body's inertial frame and r_b its centre of mass relative to the point, both
    expressed in frame_body's axes. Needs mj_kinematics (or mj_forward) to have run.
    """
    frame = model.body(frame_body).id
    origin = data.xpos[frame] if point is None else np.asarray(point, float)
    rot = data.xmat[frame].reshape(3, 3)
    total = np.zeros((3, 3))
    for name in bodies:
        b = model.body(name).id
        rb = rot.T @ data.ximat[b].reshape(3, 3)
        r = rot.T @ (data.xipos[b] - origin)
        m = model.body_mass[b]
        total += rb @ np.diag(model.body_inertia[b]) @ rb.T + m * (r @ r * np.eye(3) - np.outer(r, r))
    return total

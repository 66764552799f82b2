"""The 3D picture in the trace: moving parts built from the compiled model's geoms and placed like
MuJoCo places them, and the CMG picture of a flagship and a slew trace read back from the .rrd
(gimbals turning with the recorded angles, rotor momenta, the envelope, the H(t) path)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from rerun.chunk import RrdReader

import testbed
from testbed.recording.scene import hinge_poses, moving_parts
from testbed.systems.cmg_rhombus import ClusterGeometry, CmgRhombusParams, build
from testbed.systems.cmg_rhombus.momentum_envelope import envelope_points
from testbed.recording.scene_drawing import measure_colors
from testbed.recording.trace_reader import read_signals

ARM = """<mujoco>
  <worldbody>
    <body name="base">
      <freejoint/>
      <geom type="box" size="0.5 0.5 0.5"/>
      <body name="link" pos="0.3 -0.2 0.1" quat="0.9 0.1 -0.3 0.2">
        <joint name="swing" type="hinge" axis="0.6 0 0.8" pos="0.05 0.1 -0.02" ref="0.4"/>
        <geom type="cylinder" size="0.1 0.3" pos="0 0 0.2" quat="0.7 0.7 0 0" rgba="1 0 0 1"/>
        <geom type="sphere" size="0.05"/>
        <body name="tip" pos="0 0.4 0">
          <geom type="box" size="0.02 0.03 0.04"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"""


def test_moving_parts_are_placed_as_mujoco_places_them():
    """A hinge with an offset anchor and a reference angle: the parts' poses from hinge_poses equal
    MuJoCo's own kinematics (xpos, xquat) for random angles; shapes are the model's geoms."""
    model = mujoco.MjModel.from_xml_string(ARM)
    data = mujoco.MjData(model)
    base = model.body("base").id
    parts = {p["entity"]: p for p in moving_parts(model, base, {"swing": ("truth/swing", 0)})}
    assert sorted(parts) == ["link", "link/tip"]
    link = parts["link"]
    assert [s["kind"] for s in link["shapes"]] == ["cylinder"]  # the sphere is not drawn
    np.testing.assert_allclose(link["shapes"][0]["size"], [0.1, 0.3])
    assert link["shapes"][0]["rgba"] == [255, 0, 0, 255]
    angles = np.random.default_rng(40).uniform(-3, 3, 20)
    # the part twice, the second column's angles reversed: each column poses its own part
    both = hinge_poses([link, link], np.column_stack([angles, angles[::-1]]))
    np.testing.assert_array_equal(both[0][::-1, 1], both[0][:, 0])
    np.testing.assert_array_equal(both[1][::-1, 1], both[1][:, 0])
    translations, quats = both[0][:, 0], both[1][:, 0]
    for angle, t, q in zip(angles, translations, quats):
        data.qpos[:] = model.qpos0
        data.qpos[7] = angle
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(t, data.xpos[model.body("link").id], atol=1e-12)
        expected = data.xquat[model.body("link").id]
        np.testing.assert_allclose(q * np.sign(q @ expected), expected, atol=1e-12)
    assert parts["link/tip"]["hinge"] is None and parts["link/tip"]["pos"] == [0.0, 0.4, 0.0]


def components(path, entity: str) -> dict[str, list]:
    """{column: rows} of every chunk of `entity` in an .rrd, rows in time order."""
    out: dict[str, list] = {}
    chunks = [c.to_record_batch() for c in RrdReader(str(path)).stream() if str(c.entity_path) == f"/{entity}"]
    for batch in chunks:
        order = np.argsort(batch.column("sim_time").cast("int64").to_numpy()) if "sim_time" in batch.schema.names \
            else np.arange(batch.num_rows)
        for name in batch.schema.names:
            if ":" in name:
                column = batch.column(name).to_pylist()
                out.setdefault(name, []).extend(column[i] for i in order)
    return out


def hinged_frame_follows_mujoco(path, entity: str, model, name: str, angles, rows) -> np.ndarray:
    """Assert that the trace's transform of `entity` (a body `name` on its hinge `name`, directly on
    the bus) at each of `rows` is MuJoCo's pose at the recorded hinge angle, the bus at the origin
    (1e-6: the trace stores float32); return its quaternions (w, x, y, z), one per sample."""
    frame = components(path, entity)
    quats = np.array([q[0] for q in frame["Transform3D:quaternion"]])[:, [3, 0, 1, 2]]
    translations = np.array([p[0] for p in frame["Transform3D:translation"]])
    assert quats.shape == (len(angles), 4) and translations.shape == (len(angles), 3)
    data = mujoco.MjData(model)
    for k in rows:
        data.qpos[:] = model.qpos0
        data.qpos[model.joint(name).qposadr[0]] = angles[k]
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(translations[k], data.xpos[model.body(name).id], atol=1e-6)
        expected = data.xquat[model.body(name).id]
        np.testing.assert_allclose(quats[k] * np.sign(quats[k] @ expected), expected, atol=1e-6)
    return quats


@pytest.fixture(scope="module")
def traces(tmp_path_factory):
    """A flagship (the first 200 s of its 500) and a slew trace, written and read back."""
    folder = tmp_path_factory.mktemp("scene")
    out = {}
    for name, overrides in (("lebedev_spinup_cmg", ["sim.duration_s=200"]), ("reorient_minimax", [])):
        path = folder / f"{name}.rrd"
        result = testbed.run(name, out=path, overrides=overrides)
        assert result.status == "ok", result.error
        out[name] = (path, testbed.load(name, overrides))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", ["lebedev_spinup_cmg", "reorient_minimax"])
def test_cmg_picture_read_back_from_the_trace(traces, name):
    path, scenario = traces[name]
    signals = read_signals(path)
    t, beta = signals["truth/gimbal_angle"]
    _, momentum = signals["truth/cmg_momentum"]
    _, measure = signals["truth/singularity_measure"]
    n = len(t)
    model = build(scenario.model, scenario.sim.dt_s)
    geometry = ClusterGeometry.from_model(model)
    rows = np.linspace(0, n - 1, 12).astype(int)
    total = np.zeros((n, 3))
    arrow = components(path, "world/bus/cmg_momentum")["Arrows3D:vectors"]
    scale = np.linalg.norm(arrow[rows[-1]][0]) / np.linalg.norm(momentum[rows[-1]])
    for i in range(4):
        gimbal, rotor = f"gimbal{i + 1}", f"rotor{i + 1}"
        quats = hinged_frame_follows_mujoco(path, f"world/bus/{gimbal}", model, gimbal, beta[:, i], rows)
        box = model.geom_size[[g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body(gimbal).id][0]]
        np.testing.assert_allclose(components(path, f"world/bus/{gimbal}/boxes")["Boxes3D:half_sizes"][0][0], box, rtol=1e-6)
        disc = model.geom_size[[g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body(rotor).id][0]]
        cylinders = components(path, f"world/bus/{gimbal}/{rotor}/cylinders")
        assert cylinders["Cylinders3D:radii"][0] == pytest.approx([disc[0]], rel=1e-6)
        assert cylinders["Cylinders3D:lengths"][0] == pytest.approx([2 * disc[1]], rel=1e-6)
        # h_i in the bus frame: gimbal(t) o rotor o the rotor-frame arrow; summed below
        rotor_quat = np.array(components(path, f"world/bus/{gimbal}/{rotor}")["Transform3D:quaternion"][0][0])[[3, 0, 1, 2]]
        vector = np.array(components(path, f"world/bus/{gimbal}/{rotor}/momentum")["Arrows3D:vectors"][0][0])
        assert np.linalg.norm(vector) == pytest.approx(geometry.h * scale, rel=1e-5)
        for k in range(n):
            rot = np.zeros(9)
            mujoco.mju_quat2Mat(rot, quats[k])
            inner = np.zeros(9)
            mujoco.mju_quat2Mat(inner, rotor_quat)
            total[k] += rot.reshape(3, 3) @ inner.reshape(3, 3) @ vector
    # the four arrows add up to the drawn total, which is H(t) (nominal rotor speeds vs true: 1e-5)
    np.testing.assert_allclose(total / scale, momentum, atol=1e-4 * geometry.h)

    # the momentum view: the envelope from the model's gimbal axes and h, 7 internal surfaces
    external = np.array(components(path, "momentum_space/external")["Points3D:positions"][0])
    expected = envelope_points(geometry.alpha, 1500, geometry.h, geometry.gimbal_axes)
    assert external.shape == expected.shape and external.shape[1] == 3 and len(external) > 1400
    np.testing.assert_allclose(external, expected, atol=1e-5 * geometry.h)
    assert np.max(np.abs(external[:, 2])) == pytest.approx(4 * geometry.h, rel=1e-3)  # SEEDS §004: 4h along z
    internal = sorted(str(c.entity_path) for c in RrdReader(str(path)).stream()
                      if str(c.entity_path).startswith("/momentum_space/internal/"))
    assert len(internal) == 7
    # the path: n - 1 segments between consecutive H samples, coloured by the measure; the current point
    # streamed: one strip entity a chunk, momentum_space/path/<k>, each joined to the last
    pieces = sorted({str(c.entity_path).lstrip("/") for c in RrdReader(str(path)).stream()
                     if str(c.entity_path).startswith("/momentum_space/path/")}, key=lambda e: int(e.rsplit("/", 1)[1]))
    strips = np.concatenate([np.array(components(path, e)["LineStrips3D:strips"][0]) for e in pieces])
    assert strips.shape == (n - 1, 2, 3)
    np.testing.assert_allclose(strips[:, 0], momentum[:-1], atol=1e-5 * geometry.h)
    np.testing.assert_allclose(strips[:, 1], momentum[1:], atol=1e-5 * geometry.h)
    colors = np.concatenate([np.array(components(path, e)["LineStrips3D:colors"][0], dtype=np.uint32) for e in pieces])
    expected_rgb = measure_colors(measure[1:, 0], [0.0, (4 / 3) ** 1.5])
    np.testing.assert_array_equal(colors >> 24, expected_rgb[:, 0])
    np.testing.assert_array_equal((colors >> 16) & 255, expected_rgb[:, 1])
    now = np.array([p[0] for p in components(path, "momentum_space/now")["Points3D:positions"]])
    assert now.shape == (n, 3)
    np.testing.assert_allclose(now, momentum, atol=1e-5 * geometry.h)
    np.testing.assert_allclose(measure[:, 0], geometry.singularity_measure(beta), rtol=1e-9)


def test_a_trace_with_no_signal_opens_on_its_stored_result():
    """No plot to show (a run stopped before its first sample): the blueprint's right side is the
    result document, at the entity the writer stores it under."""
    from testbed.recording.blueprint import RESULT_ENTITY, blueprint

    right = blueprint([], 1.0, None).root_container.contents[-1]
    assert type(right).__name__ == "TextDocumentView" and str(right.origin) == f"/{RESULT_ENTITY}"


ORBIT_CMG_KEYS = ["truth/omega", "truth/quat", "truth/quat_lvlh", "truth/angular_momentum_world",
                  "truth/gimbal_angle", "truth/gimbal_rate", "truth/rotor_rate", "truth/cmg_momentum",
                  "truth/singularity_measure", "truth/envelope_share", "truth/orbit_position",
                  "truth/orbit_velocity", "truth/eclipse", "truth/sun_direction", "truth/magnetic_field",
                  "truth/torque_gravity_gradient", "truth/torque_drag", "truth/torque_environment",
                  "truth/magnetorquer_dipole", "truth/magnetometer", "sensor/quat", "sensor/omega",
                  "estimator/quat", "estimator/omega", "law/torque", "law/attitude_error",
                  "allocator/gimbal_rates", "allocator/scale", "reference/omega_error"]


def _tabs(bp):
    """{tab name: [view names]} of a blueprint whose right side is the Tabs container."""
    tabs = bp.root_container.contents[-1]
    return tabs, {getattr(t, "name", None): [getattr(v, "name", None) for v in getattr(t, "contents", None) or []]
                  for t in tabs.contents}


def test_an_orbit_runs_signals_go_to_one_tab_a_subsystem_and_it_opens_on_the_result():
    """Issue 39: one 'truth' tab held 24 plots; now attitude, cluster, orbit and environment,
    sensors and estimator, law and steering, and the result, which it opens on."""
    from testbed.recording.blueprint import RESULT_TAB, blueprint, tab_of

    scene = {"body_momenta": {"truth/cmg_momentum": "cmg_momentum"}, "units": {"cmg_momentum": "N m s"}}
    tabs, views = _tabs(blueprint(ORBIT_CMG_KEYS, 100.0, scene))
    assert list(views) == ["attitude", "cluster", "orbit and environment", "sensors and estimator",
                           "law and steering", RESULT_TAB]
    assert tabs.active_tab == RESULT_TAB
    held = frozenset(scene["body_momenta"])
    assert {k for k in ORBIT_CMG_KEYS if tab_of(k, held) == "cluster"} == {
        "truth/gimbal_angle", "truth/gimbal_rate", "truth/rotor_rate", "truth/cmg_momentum",
        "truth/singularity_measure", "truth/envelope_share"}
    assert tab_of("truth/torque_drag") == tab_of("truth/orbit_position") == "orbit and environment"
    assert tab_of("truth/magnetometer") == tab_of("estimator/quat") == "sensors and estimator"
    assert tab_of("allocator/scale") == tab_of("law/torque") == "law and steering"
    assert tab_of("reference/omega_error") == tab_of("truth/quat") == "attitude"
    assert max(len(v) for v in views.values()) <= 10  # no tab packs two dozen plots
    # titles short enough to read and with their unit
    assert "omega [rad/s]" in views["attitude"] and "torque_drag [N m]" in views["orbit and environment"]
    assert "magnetic_field [T]" in views["orbit and environment"] and "gimbal_angle [rad]" in views["cluster"]


def test_legends_give_every_component_with_its_unit():
    from testbed.recording.blueprint import UNITS, series_names

    assert series_names("gimbal_rate", 4, UNITS) == [f"gimbal {i} [rad/s]" for i in (1, 2, 3, 4)]
    assert series_names("rotor_rate", 4, UNITS) == [f"rotor {i} [rad/s]" for i in (1, 2, 3, 4)]
    assert series_names("omega", 3, UNITS) == ["x [rad/s]", "y [rad/s]", "z [rad/s]"]
    assert series_names("torque_solar_pressure", 3, UNITS)[0] == "x [N m]"
    assert series_names("quat_lvlh", 4, UNITS) == ["w", "x", "y", "z"]
    assert series_names("kinetic_energy", 1, UNITS) == ["kinetic_energy [J]"]

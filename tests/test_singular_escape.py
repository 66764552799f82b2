"""Wie 2005's singular start, flown (scenarios/pyramid_singular_escape.yaml): the pseudo-inverse and
Wie's off-diagonal SR inverse side by side from the 53.13 deg pyramid at (-90, 0, 90, 0) deg under a
constant torque along the singular direction x (docs/theory/steering.md, "Escaping a singular start")."""

from __future__ import annotations

import numpy as np
import pytest

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

H, TORQUE, STOP_S = 25.0, 5.0, 8.0  # the scenario's rotor momentum [N m s], |M| [N m], end of the torque [s]


def flown(law: str):
    result = run_scenario(load_scenario("pyramid_singular_escape", [f"pipeline.allocator.type={law}"]), None,
                          keep_data=True)
    assert result.status == "ok", result.error
    return result


@pytest.mark.slow
def test_pinv_stays_on_the_singular_start_and_osr_leaves_it():
    """At the start every torque axis lies in the yz plane (x the singular direction, H = 2h cos b x =
    1.2 h: exact by hand), so the pseudo-inverse's rates are zero to round-off and nothing is ever
    delivered: torque_error_rel = 1 and the cluster keeps H = (30, 0, 0) N m s to round-off (a
    band of 1e-9 h: the servos hold the angles to 1e-13 deg). Wie's law leaves the singular set
    (sqrt det J J^T >= 0.1) within 5 s (measured 3.45 s, driven by its deterministic dither: a 1e-10 deg
    change of the start moves the metrics by 1e-11), then, once lambda0 exp(-mu det) < 2e-5, delivers
    the demand to 1e-3 until the torque stops. The bus's momentum I_x w_x at the end is the demand
    after the escape, M (8 s - t_escape) = -22.75 N m s, to 5 % (measured -22.2 N m s: what was
    delivered during the escape and the bus's small turn about y and z account for the rest)."""
    pinv = flown("pinv")
    assert pinv.metrics["torque_error_rel"] == pytest.approx(1.0, abs=1e-9)
    assert pinv.metrics["peak_gimbal_rate_deg_s"] < 1e-6
    _, held = pinv.trace["truth/cmg_momentum"]
    np.testing.assert_allclose(held, np.broadcast_to([2 * H * 0.6, 0.0, 0.0], held.shape), rtol=0, atol=1e-9 * H)

    osr = flown("osr")
    t, measure = osr.trace["allocator/singularity"]
    measure = measure.ravel()
    escape_s = t[np.argmax(measure >= 0.1)]
    assert measure.max() >= 0.1 and 0.0 < escape_s <= 5.0, escape_s
    _, wanted = osr.trace["law/torque"]
    _, delivered = osr.trace["allocator/torque_delivered"]
    after = (measure >= 0.8) & (t < STOP_S - 0.05)  # lambda = lambda0 exp(-mu det) < 2e-5
    assert after.sum() > 40  # 2 s of control samples at 0.05 s
    np.testing.assert_allclose(delivered[after], wanted[after], rtol=0, atol=1e-3 * TORQUE)
    assert osr.metrics["torque_error_rel"] <= 0.8 < pinv.metrics["torque_error_rel"]
    # the bus's momentum along x (inertial = body at the end's small angle): I_x w_x vs the torque delivered
    _, omega = osr.trace["truth/omega"]
    given = 800.0 * omega[-1, 0]
    demanded = -TORQUE * (STOP_S - escape_s)
    assert given < 0 and abs(given - demanded) <= 0.05 * abs(demanded), (given, demanded)


@pytest.mark.slow
@pytest.mark.parametrize("overrides, torque", [
    # not shipped: the 54.74 deg pyramid, h = 40 N m s on a lighter bus, the same 0.2 h/s along +x
    (["model.array.skew_deg=54.7356", "model.rotor_momentum_nms=40", "model.inertia_kg_m2=[300, 500, 400]",
      "pipeline.law.offset=[-8, 0, 0]"], 8.0),
    # not shipped: the demand the other way along u, towards the origin
    (["pipeline.law.offset=[5, 0, 0]"], -5.0),
])
def test_the_escape_on_cases_not_shipped(overrides, torque):
    """The same comparison off the shipped case: pinv delivers nothing (torque_error_rel = 1), osr
    leaves the singular set within 5 s (measured 3.15 s, and 0.85 s along -u) and then, once
    sqrt det >= 0.8, delivers the demand to 1e-3 of it. (On the lighter bus the body turns at up to
    0.13 rad/s and the reduced model's rate differs by 1.8e-7 rad/s, beyond the shipped 1e-8: not
    asserted here.)"""
    for law in ("pinv", "osr"):
        result = run_scenario(load_scenario("pyramid_singular_escape",
                                            [*overrides, f"pipeline.allocator.type={law}"]), None, keep_data=True)
        assert result.status == "ok", result.error
        t, measure = result.trace["allocator/singularity"]
        measure = measure.ravel()
        if law == "pinv":
            assert result.metrics["torque_error_rel"] == pytest.approx(1.0, abs=1e-9)
            assert measure.max() < 1e-9  # the servos hold the angles: sqrt det drifts to ~2e-12
            continue
        assert measure.max() >= 0.1 and t[np.argmax(measure >= 0.1)] <= 5.0
        _, wanted = result.trace["law/torque"]
        _, delivered = result.trace["allocator/torque_delivered"]
        after = (measure >= 0.8) & (t < STOP_S - 0.05)
        assert after.sum() > 20
        np.testing.assert_allclose(delivered[after], wanted[after], rtol=0, atol=1e-3 * abs(torque))

"""Issue 28: a run stepped a control period at a time, and Python objects as stages.

Independent numbers: `testbed.run` of the same scenario (its loop run to the end at once) for
bit-identity, every metric and every trace array compared with ==; a registered plug-in law
of the same class for a Python object in the slot; the campaign's own case draws for the
dispersions of a seed; the output checks' refusals by their messages.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

import testbed
from testbed.campaign.cases import expand
from testbed.campaign.spec import case_seed
from testbed.scenario.loading import field_value, load_mapping

SLEW = ("reorient_minimax", ["sim.duration_s=6"])  # 120 control periods, the slew under way from 5 s
MULTIRATE = ("lebedev_spinup_cmg", ["sim.duration_s=3", "sim.estimator_period_s=0.01"])  # 5 samples a period


def assert_same_run(a, b):
    """Every metric, check and trace array of two runs equal, bit for bit."""
    assert (a.status, a.error, a.sim_s) == (b.status, b.error, b.sim_s)
    assert a.metrics == b.metrics and a.checks == b.checks
    assert sorted(a.trace) == sorted(b.trace) and len(a.trace) > 10
    for key in a.trace:
        (ta, va), (tb, vb) = a.trace[key], b.trace[key]
        assert np.array_equal(ta, tb) and np.array_equal(va, vb), key


def stepped(scenario, overrides, **kwargs):
    sim = testbed.Simulation(scenario, overrides, **kwargs)
    while sim.running:
        sim.step()
    return sim, sim.close()


@pytest.mark.parametrize("case", [SLEW, MULTIRATE], ids=["slew", "multirate"])
def test_stepping_with_the_built_in_stages_is_the_run_bit_for_bit(case):
    sim, result = stepped(*case)
    assert sim.ticks == sim.n_ticks and result.status == "ok"
    assert_same_run(result, testbed.run(case[0], overrides=case[1]))


def test_the_state_and_the_outputs_are_read_between_steps():
    sim = testbed.Simulation(*SLEW)
    tc = sim.scenario.sim.control_period_s
    for k in range(3):
        outputs = sim.step()
        assert sim.ticks == k + 1 and sim.time == pytest.approx((k + 1) * tc, abs=1e-12)
    # the attitude sensor is ideal: what the sensor read at t = 2 Tc is the truth of that instant
    truth_then = sim.outputs["sensor"]["quat"]
    assert np.array_equal(outputs["estimator"]["quat"], truth_then)
    assert set(sim.truth()) >= {"omega", "quat"} and sim.outputs["allocator"]["gimbal_rates"].shape == (4,)
    sim.close()


def test_a_command_given_for_a_step_replaces_that_slot_and_is_checked():
    # the slew law's torque of each period, taken from a second run, given as the command: the
    # same run (the steering, the plant and the trace see the same torque)
    sim, reference = testbed.Simulation(*SLEW), testbed.Simulation(*SLEW)
    while reference.running:
        reference.step()
        sim.step({"law": {"torque": reference.outputs["law"]["torque"]}})
    given, configured = sim.close(), reference.close()
    for key in ("truth/quat", "truth/omega", "law/torque", "allocator/gimbal_rates"):
        assert np.array_equal(given.trace[key][1], configured.trace[key][1]), key
    assert "law/program_quat" in configured.trace and "law/program_quat" not in given.trace
    with pytest.raises(RuntimeError, match="closed"):
        sim.step()

    bad = testbed.Simulation(*SLEW)
    with pytest.raises(testbed.InputError, match=r"command\.law.*shape \(2,\), expected \(3,\)"):
        bad.step({"law": {"torque": np.zeros(2)}})
    with pytest.raises(testbed.InputError, match=r"command\.law.*not finite"):
        bad.step({"law": {"torque": [np.nan, 0, 0]}})
    with pytest.raises(testbed.InputError, match=r"command\.allocator.*one of \[[^]]*'gimbal_rates'"):
        bad.step({"allocator": {"rates": np.zeros(4)}})
    with pytest.raises(testbed.InputError, match="unknown slot 'steering'"):
        bad.step({"steering": {}})
    assert bad.ticks == 0 and bad.running  # nothing ran
    bad.step({"allocator": {"gimbal_rates": np.full(4, 0.01)}})
    assert bad.ticks == 1 and np.array_equal(bad.outputs["allocator"]["gimbal_rates"], np.full(4, 0.01))
    bad.step()  # the configured allocator is back
    assert bad.ticks == 2 and bad.pipeline.allocator.type_name == "minimax"
    bad.close()


def test_a_seed_draws_the_campaigns_dispersions_of_that_case_seed():
    data, _ = load_mapping("reorient_campaign")
    j = 3
    case = expand(data, indices=[j])[0]  # the campaign's own case j, drawn from case_seed(12, j)
    sim = testbed.Simulation("reorient_campaign", ["sim.duration_s=1"], seed=case_seed(12, j))
    for key in ("pipeline.law.axis", "pipeline.law.angle_deg"):
        assert field_value(sim.scenario, key) == case.values[key], key
    first = sim.scenario.stages["law"][1]
    sim.reset(seed=case_seed(12, j))
    assert sim.scenario.stages["law"][1] == first          # the same seed, the same case
    sim.reset(seed=7)
    assert sim.scenario.stages["law"][1].axis != first.axis
    sim.reset()
    assert field_value(sim.scenario, "pipeline.law.angle_deg") == 90  # no seed: the nominal scenario
    with pytest.raises(testbed.InputError, match="seed: must be an integer"):
        sim.reset(seed=-1)
    sim.close()


def test_the_trace_of_a_stepped_run_is_written_to_its_rrd(tmp_path):
    out = tmp_path / "stepped.rrd"
    _, result = stepped(*SLEW, out=out, keep_trace=False)
    back = testbed.read(out)
    assert (back.status, back.metrics) == ("ok", result.metrics)
    assert np.array_equal(back.trace["truth/quat"][1], testbed.run(*SLEW[:1], overrides=SLEW[1]).trace["truth/quat"][1])


# --- Python objects as stages -----------------------------------------------------------------

@dataclass
class GainParams:
    kp: float = testbed.param(400.0, gt=0)
    kd: float = testbed.param(800.0, gt=0)


class RateDamping:
    """A plain law: torque = -kp q_v sign(q_w) - kd omega (a quaternion-feedback PD to rest)."""

    outputs = ("torque",)

    def __init__(self, params=GainParams(), ctx=None):
        self.kp, self.kd = params.kp, params.kd

    def torque(self, t, estimate):
        q, w = estimate["quat"], estimate["omega"]
        return {"torque": -self.kp * np.sign(q[0]) * q[1:] - self.kd * w}


testbed.stage("law", "tests.rate_damping", GainParams)(type("RegisteredRateDamping", (RateDamping,), {}))
TUMBLE = ["sim.duration_s=2", "initial.omega_deg_s=[0.5, -0.3, 0.2]", "checks={}"]


def test_a_python_object_as_the_law_is_the_same_law_registered():
    registered = testbed.run("reorient_minimax", overrides=TUMBLE + ["pipeline.law={type: tests.rate_damping}"])
    given = testbed.run("reorient_minimax", overrides=TUMBLE, stages={"law": RateDamping()})
    assert registered.status == given.status == "ok"
    for key in ("truth/omega", "law/torque", "allocator/gimbal_rates"):
        assert np.array_equal(registered.trace[key][1], given.trace[key][1]), key
    law = RateDamping()
    function = testbed.run("reorient_minimax", overrides=TUMBLE, stages={"law": law.torque})
    assert np.array_equal(function.trace["truth/omega"][1], given.trace["truth/omega"][1])


class Returns:
    def __init__(self, value):
        self.value = value

    def torque(self, t, estimate):
        return self.value(t) if callable(self.value) else self.value


@pytest.mark.parametrize("law, reason", [
    (Returns([1.0, 2.0]), "returned list, not a dict of arrays"),
    (Returns({"torque": np.zeros(2)}), "key 'torque' has shape (2,), expected (3,)"),
    (Returns(lambda t: {"torque": np.array([np.inf, 0, 0]) if t > 0.1 else np.zeros(3)}),
     "key 'torque' is not finite: [inf, 0.0, 0.0]"),
    (Returns({"torque": np.array([1e-3j, 0, 0])}), "returned a complex 'torque': "),
    (Returns(lambda t: 1 / 0), "ZeroDivisionError: division by zero"),
])
def test_a_python_object_is_held_to_a_plugins_output_checks(law, reason):
    result = testbed.run("reorient_minimax", overrides=TUMBLE, stages={"law": law})
    assert result.status == "error" and result.error.startswith("stage law 'Returns' failed at t = "), result.error
    assert reason in result.error


@pytest.mark.parametrize("stages, message", [
    ({"law": RateDamping}, "stages.law: got the class RateDamping: pass an instance"),
    ({"law": 3}, "stages.law: int has no torque method and is not a function"),
    ({"planner": RateDamping()}, "stages: unknown slot 'planner'"),
    ({"allocator": Returns({})}, "stages.allocator: Returns has no allocate method"),
    ({"allocator": type("A", (), {"allocate": lambda *a: {}})()}, "stages.allocator: an allocator names its command key"),
    ([RateDamping()], "stages: must be a mapping"),
])
def test_an_object_that_cannot_take_the_slot_is_refused_before_the_run(stages, message):
    with pytest.raises(testbed.InputError) as refused:
        testbed.run("reorient_minimax", overrides=TUMBLE, stages=stages)
    assert str(refused.value).startswith(message), str(refused.value)


def test_a_given_estimate_without_a_key_the_law_reads_is_named_as_the_reason():
    """An estimator output given without `quat`: the law that reads it fails its step, as any
    stage whose input lacks a key, and the one-line reason names the given output (before:
    KeyError: 'quat', blamed on the law alone)."""
    import numpy as np

    sim = testbed.Simulation("slew_quaternion_feedback_mekf", ["sim.duration_s=2"])
    sim.step()
    sim.step({"estimator": {"omega": np.zeros(3)}})
    assert sim.status == "error" and sim.ticks == 1
    assert sim.error.startswith("stage law 'quaternion_feedback' failed at t = 0.1 s")
    assert "'quat', which the estimator output given to Simulation.step lacks" in sim.error
    sim.close()


def test_a_given_output_without_the_keys_its_slot_gives_is_refused_before_the_step():
    """Third hostile round: a law's output without `torque` was run (the run went on, status ok);
    and a keep_trace that is not a bool was taken as true."""
    import numpy as np

    sim = testbed.Simulation("reorient_minimax", ["sim.duration_s=0.5"])
    sim.step()
    for command, field in (({"law": {"tork": np.array([5.0, 0, 0])}}, "command.law"), ({"law": {}}, "command.law")):
        with pytest.raises(testbed.InputError) as err:
            sim.step(command)
        assert err.value.field == field and "missing key" in err.value.reason
    assert sim.ticks == 1 and sim.status == "ok"
    sim.close()
    with pytest.raises(testbed.InputError, match="keep_trace"):
        testbed.Simulation("reorient_minimax", ["sim.duration_s=0.5"], keep_trace="no")


def test_a_run_closed_before_its_end_keeps_the_periods_after_its_last_trace_sample():
    """10 s stepped of a 20 s run sampled every 10 s closed with sim_s 0 and no metrics: the periods
    after the sample at t = 0 were dropped. Closed there, it is the 10 s run (a second method)."""
    sets = ["sim.duration_s=20", "sim.trace_period_s=10", "sim.control_period_s=0.5", "sim.dt_s=0.1"]
    sim = testbed.Simulation("orbit_momentum_management", sets, keep_trace=False)
    for _ in range(20):
        sim.step()
    early = sim.close()
    whole = testbed.run("orbit_momentum_management", overrides=[*sets, "sim.duration_s=10"])
    assert early.sim_s == whole.sim_s == 10.0
    assert early.metrics.keys() == whole.metrics.keys() and early.metrics
    # the same periods: equal but for round-off (peak_envelope_share differs by one ulp)
    np.testing.assert_allclose(list(early.metrics.values()), list(whole.metrics.values()), rtol=1e-15, atol=0)


def test_the_time_of_a_stepped_run_is_on_its_grid():
    """500 periods of 0.2 s are 100 s exactly (MuJoCo's clock, adding dt, read 100.00000000001407)."""
    sim = testbed.Simulation("reorient_minimax", ["sim.control_period_s=0.2", "sim.trace_period_s=0.2",
                                                  "sim.duration_s=120"], keep_trace=False)
    for _ in range(500):
        sim.step()
    assert sim.time == 100.0 and sim.ticks == 500
    sim.close()

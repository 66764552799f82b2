"""Issue 16, part 2: sensor and estimator at their own sample period, a divisor of the law's.

Independent numbers: the default one-rate run reproduced bit for bit, the first-order
convergence of the held-measurement observer in its own period at a fixed law period (against
the continuous-time reference), the sample instants of every recorded stage, conservation of
angular momentum with a CMG cluster.
"""

import numpy as np
import pytest

from testbed.errors import InputError
from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario
from test_lebedev_reference import OTHER_CASE



def test_the_control_period_given_as_estimator_period_is_the_one_rate_run():
    base = ["sim.duration_s=200"]
    one = run_scenario(load_scenario("lebedev_spinup_ideal", base), None, keep_data=True)
    same = run_scenario(load_scenario("lebedev_spinup_ideal", base + ["sim.estimator_period_s=0.0625"]), None,
                        keep_data=True)
    assert np.array_equal(one.data.recorder["truth/omega"], same.data.recorder["truth/omega"])
    assert one.metrics == same.metrics


def test_each_stage_is_recorded_at_its_own_rate():
    run = run_scenario(load_scenario("lebedev_spinup_ideal", [
        "sim.duration_s=2", "sim.dt_s=0.0125", "sim.estimator_period_s=0.0125", "sim.trace_period_s=0.0125",
        "pipeline.estimator.max_substep_s=0.0125", "reference=", "checks={}"]), None, keep_data=True)
    assert run.status == "ok"
    for key, period in (("truth/omega", 0.0125), ("sensor/y", 0.0125), ("estimator/z", 0.0125),
                        ("law/torque", 0.0625), ("allocator/body_torque", 0.0625)):
        times, _ = run.trace[key]
        assert np.diff(times) == pytest.approx(period, abs=1e-12), key
    stamps = run.trace["sensor/stamp"][1][:, 0]
    assert np.diff(stamps) == pytest.approx(0.0125, abs=1e-12)   # the gyro samples at its own rate


@pytest.mark.parametrize("overrides, field", [
    (["sim.dt_s=0.0125", "sim.estimator_period_s=0.025"], "sim.control_period_s"),   # does not divide 0.0625
    (["sim.estimator_period_s=0.01"], "sim.estimator_period_s"),                      # not a multiple of dt
    (["sim.dt_s=0.0125", "sim.estimator_period_s=0.025", "sim.control_period_s=0.075",
      "sim.trace_period_s=0.0375"], "sim.trace_period_s"),                           # not a multiple of it
])
def test_periods_that_do_not_nest_are_refused(overrides, field):
    with pytest.raises(InputError) as refused:
        load_scenario("lebedev_spinup_ideal", overrides)
    assert refused.value.field == field


def test_cmg_spacecraft_keeps_its_momentum_at_two_rates():
    run = run_scenario(load_scenario("lebedev_spinup_cmg", ["sim.duration_s=200", "sim.estimator_period_s=0.01",
                                                            "sim.trace_period_s=0.05"]), None)
    assert run.status == "ok"
    assert run.metrics["momentum_drift_rel"] < 1e-9


@pytest.mark.slow
def test_held_measurement_error_is_first_order_in_the_estimator_period(tmp_path):
    """Law period fixed at 0.04 s; the observer with y held over its own period Ts is the
    loop's dominant error and halves with Ts (measured over 400 s: 0.514, 0.258, 0.131, 0.067
    deg/s at Ts = 0.04, 0.02, 0.01, 0.005 s), so multi-rate sampling buys what one fast rate
    would, at the law period unchanged."""
    case = tmp_path / "other_case.yaml"
    case.write_text(OTHER_CASE)
    deviation = {}
    for ts in (0.02, 0.01, 0.005):
        run = run_scenario(load_scenario(str(case), ["sim.control_period_s=0.04", "sim.trace_period_s=0.04",
                                                     f"sim.dt_s={ts}", f"sim.estimator_period_s={ts}",
                                                     f"pipeline.estimator.max_substep_s={ts}"]), None)
        assert run.status == "ok"
        deviation[ts] = run.metrics["max_deviation_from_continuous_deg_s"]
    assert deviation[0.02] / deviation[0.01] == pytest.approx(2.0, rel=0.05)
    assert deviation[0.01] / deviation[0.005] == pytest.approx(2.0, rel=0.05)

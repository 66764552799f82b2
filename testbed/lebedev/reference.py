"""Reference `lebedev_continuous`: the continuous-time closed loop of a Lebedev scenario.

Built from the scenario's own design (the `rate_gyro` axis and bias, the `lebedev` observer's
poles and start-up, the `lebedev` law's Omega and gains) and the plant at t = 0 (locked
inertia, w(0), the internal momentum H(0)), and solved by
testbed.lebedev.continuous with nothing sampled: `reference/omega` is what the
sampled loop converges to as its periods shrink, and the metric
`max_deviation_from_continuous_deg_s` (testbed/lebedev/metrics.py) says how far it is.
"""

from __future__ import annotations


from testbed.errors import InputError
from testbed.lebedev.continuous import closed_loop_states
from testbed.pipeline import output_of
from testbed.references.registry import reference

NAME = "lebedev_continuous"


def _require(scenario, slot: str, wanted: str) -> None:
    got = scenario.stages[slot][0]
    if got != wanted:
        raise InputError("reference.type", f"{NAME} needs pipeline.{slot}.type {wanted}, got {got!r}")


@reference(NAME, systems=("satellite", "cmg_rhombus"), with_scenario=True)
def _lebedev_continuous(plant, params, scenario):
    """The continuous closed loop (eq. 3.1, 4.6, 4.7) from the plant's state at t = 0."""
    from testbed.lebedev.stage import LebedevEstimator

    for slot, wanted in (("sensor", "rate_gyro"), ("estimator", "lebedev"), ("law", "lebedev")):
        _require(scenario, slot, wanted)
    sensor, observer_params, law = (scenario.stages[slot][1] for slot in ("sensor", "estimator", "law"))
    inertia_matrix = plant.locked_inertia()
    observer = LebedevEstimator.build_observer(observer_params, inertia_matrix, law.omega_ref, sensor.axis)
    internal = output_of("allocator", scenario.stages["allocator"][0]) != "body_torque"
    omega0, momentum0 = plant.omega().copy(), plant.internal_momentum_body().copy()

    def evaluate(times, recorder):
        return closed_loop_states(observer, law.gains_per_s, observer_params.startup_s, omega0, momentum0,
                                  times - times[0], internal=internal, bias=sensor.bias_rad_s)[:, :3]

    return evaluate

"""Metrics of the orbit itself, from the run's truth (`truth/orbit_position`, `truth/orbit_velocity`):
what the orbit validation scenarios check (docs/theory/environment.md, "Validation")."""

from __future__ import annotations

import numpy as np

from testbed.metrics import metric
from testbed.orbit.node_rate import first_order_node_rate, measured_node_rate
from testbed.orbit.sgp4_check import sgp4_positions

ORBIT_STATE = ("truth/orbit_position", "truth/orbit_velocity")


def _drifting_node(scenario) -> bool:
    """An orbit of elements propagated with J2 under an uncontrolled bus (a validation run of the
    orbit: a controlled run keeps no orbit history)."""
    o = scenario.orbit
    return o is not None and o.tle is None and o.j2 and scenario.stages["law"][0] == "none"


@metric("node_rate_error_rel", applies=_drifting_node, uses=ORBIT_STATE)
def node_rate_error_rel(run) -> float:
    """|dΩ/dt measured / (-(3/2) n̄ J2 (R/p)² cos i) - 1|: the node's drift against its closed form.

    The drift between the first and last ascending-node crossing of the truth, against the
    first-order closed form of the mean elements averaged over those whole turns
    (testbed.orbit.node_rate)."""
    t = run.recorder.time
    rate, elements = measured_node_rate(t, run.recorder["truth/orbit_position"], run.recorder["truth/orbit_velocity"])
    return float(abs(rate / first_order_node_rate(*elements) - 1.0))


def _from_tle(scenario) -> bool:
    return scenario.orbit is not None and scenario.orbit.tle is not None


@metric("sgp4_position_error_m", applies=_from_tle, uses=("truth/orbit_position",))
def sgp4_position_error_m(run) -> float:
    """max over the trace of |r - r_SGP4| [m]: the run's orbit against SGP4 called directly.

    SGP4 at the update instant each sample holds, turned into the GCRS by the equinox route
    (testbed.orbit.sgp4_check; the two routes differ by ≤ 1.9e-7 rad, the interpolation between
    SGP4's grid states by ~1 cm)."""
    scenario = run.scenario
    period = (scenario.environment.update_period_s if scenario.environment is not None
              else scenario.sim.control_period_s)
    # the environment's update is due from half a control tick early (surroundings.py)
    held = np.floor((run.recorder.time + 0.5 * scenario.sim.control_period_s) / period) * period
    expected = sgp4_positions(scenario.orbit.satrec, scenario.orbit.epoch(), held)
    return float(np.max(np.linalg.norm(run.recorder["truth/orbit_position"] - expected, axis=1)))

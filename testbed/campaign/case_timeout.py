"""How long one case of a campaign may run before the engine gives up on it
(testbed.campaign.engine): STARTUP_S + STEP_S per physics step (sim.duration_s / sim.dt_s).

STEP_S, 1 ms of wall time a step, is about 20 times what a step of the slowest shipped campaign
costs (reorient_campaign: 85 s at dt 0.002 s, 42 500 steps in 1.5-2.5 s of CPU: 35-60 us) and
about 50 times the flagship spin-up's (250 000 steps in 4-5 s); STARTUP_S covers a worker's
first imports and the plant's build on a loaded machine. `--case-timeout SECONDS` replaces it.
"""

from __future__ import annotations

import math

from testbed.errors import InputError, quoted

STARTUP_S = 60.0
STEP_S = 1e-3


def case_timeout_s(scenario) -> float:
    """The wall-time bound of one case of `scenario` (a testbed.scenario.loading.Scenario) [s]."""
    return STARTUP_S + scenario.sim.duration_s / scenario.sim.dt_s * STEP_S


def checked_case_timeout(text: str) -> float:
    """`--case-timeout`'s value: a positive finite number of seconds; InputError otherwise."""
    try:
        seconds = float(text)
    except ValueError:
        seconds = math.nan
    if not (math.isfinite(seconds) and seconds > 0):
        raise InputError("--case-timeout", f"must be a positive finite number of seconds, got {quoted(text)}")
    return seconds

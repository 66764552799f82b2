"""Metrics of the Lebedev one-gyro spin control runs (issue 4): spin error, estimation error.

The spin target is w* = (0, 0, Omega) (Task 1) or (0, 0, Omega*) (Task 2), Lebedev 1976,
eq. 4.1 and section 5. Estimation errors compare the estimator's `omega` with the truth at
the same trace samples: evaluation after the run, never fed back. Rates are in deg/s, as the
paper reports them. "Steady" means the last STEADY_FRACTION of the run. The CMG-actuated runs
use the steering metrics of testbed.steering.metrics (rate_limit_violations, ...).
Every metric is a running reduction (testbed.recording.reductions), so a run keeps no signal's history
for them; the windows over the end of the run are testbed.recording.reductions.TailMean / TailNanMax.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.metrics import OMEGA_ERROR, metric
from testbed.recording.reductions import FirstFrom, Last, MaxNorm, NanMaxBefore, TailMean, TailNanMax

STEADY_FRACTION = 0.2
FINAL_FRACTION = 0.1


def _law_is_lebedev(scenario) -> bool:
    return scenario.stages["law"][0] == "lebedev"


def _estimator_is_lebedev(scenario) -> bool:
    return scenario.stages["estimator"][0] == "lebedev"


def _is_detumble(scenario) -> bool:
    return _law_is_lebedev(scenario) and scenario.stages["law"][1].task == "detumble"


def _target(scenario) -> tuple:
    return (0.0, 0.0, scenario.stages["law"][1].omega_ref)


@dataclass(frozen=True)
class _SpinError:
    """Per trace sample: |e|, e_z and e_x^2 + e_y^2 of e = w - (0, 0, Omega) [deg/s, (deg/s)^2]."""

    target: tuple

    def __call__(self, chunk):
        if "truth/omega" not in chunk:
            return None
        e = np.degrees(chunk["truth/omega"] - np.array(self.target))
        return np.column_stack([np.linalg.norm(e, axis=1), e[:, 2], np.sum(e[:, :2] ** 2, axis=1)])


def _estimation_error(chunk):
    """|w_hat - w| [deg/s] per trace sample (NaN where the estimator did not run)."""
    if "estimator/omega_estimate" not in chunk:
        return None
    return np.degrees(np.linalg.norm(chunk["estimator/omega_estimate"] - chunk["truth/omega"], axis=1))


def _steady(scenario) -> TailMean:
    """Means of |e|, e_z, e_x^2 + e_y^2 over the last STEADY_FRACTION of the run."""
    return TailMean(_SpinError(_target(scenario)), STEADY_FRACTION, scenario.sim.end_time_s)


def _startup_s(scenario) -> float:
    return scenario.stages["estimator"][1].startup_s


def _startup(scenario) -> NanMaxBefore:
    return NanMaxBefore(_estimation_error, _startup_s(scenario))


def _at_closing(scenario) -> FirstFrom:
    return FirstFrom(_estimation_error, _startup_s(scenario))


def _final(scenario) -> TailNanMax:
    return TailNanMax(_estimation_error, FINAL_FRACTION, scenario.sim.end_time_s)


OMEGA_LAST = Last("truth/omega")
OMEGA_PEAK = MaxNorm("truth/omega")


@metric("spin_error_final_deg_s", applies=_law_is_lebedev, uses=(OMEGA_LAST,))
def spin_error_final_deg_s(run) -> float:
    """|w(T) - (0, 0, Omega)| at the end of the run [deg/s] (Lebedev 1976, eq. 4.1)."""
    return float(np.linalg.norm(np.degrees(run.reduced(OMEGA_LAST) - np.array(_target(run.scenario)))))


@metric("spin_error_steady_deg_s", applies=_law_is_lebedev, uses=lambda s: (_steady(s),))
def spin_error_steady_deg_s(run) -> float:
    """Mean of |w - (0, 0, Omega)| over the last 20 % of the run [deg/s]."""
    return float(run.reduced(_steady(run.scenario))[0])


@metric("spin_rate_offset_deg_s", applies=_law_is_lebedev, uses=lambda s: (_steady(s),))
def spin_rate_offset_deg_s(run) -> float:
    """Mean of w_z - Omega over the last 20 % of the run [deg/s] (a gyro bias b gives -b / gamma)."""
    return float(run.reduced(_steady(run.scenario))[1])


@metric("transverse_rate_steady_deg_s", applies=_law_is_lebedev, uses=lambda s: (_steady(s),))
def transverse_rate_steady_deg_s(run) -> float:
    """RMS of sqrt(w_x^2 + w_y^2) over the last 20 % of the run [deg/s] (nutation left)."""
    return float(np.sqrt(run.reduced(_steady(run.scenario))[2]))


@metric("peak_body_rate_deg_s", applies=_law_is_lebedev, uses=(OMEGA_PEAK,))
def peak_body_rate_deg_s(run) -> float:
    """max over the run of |w| [deg/s]: stays near max(|w(0)|, Omega) when the loop is stable."""
    return float(np.degrees(run.reduced(OMEGA_PEAK)))


@metric("residual_rate_final_deg_s", applies=_is_detumble, uses=(OMEGA_LAST,))
def residual_rate_final_deg_s(run) -> float:
    """|w(T)| after detumbling [deg/s]; Task 2 leaves the admissible residual Omega* (section 5)."""
    return float(np.degrees(np.linalg.norm(run.reduced(OMEGA_LAST))))


@metric("estimation_error_startup_deg_s", applies=_estimator_is_lebedev, uses=lambda s: (_startup(s),))
def estimation_error_startup_deg_s(run) -> float:
    """max |w_hat - w| during the start-up phase, t < startup_s [deg/s] (z(0) = 0, so it is > 0)."""
    return float(run.reduced(_startup(run.scenario)))


@metric("estimation_error_at_closing_deg_s", applies=_estimator_is_lebedev, uses=lambda s: (_at_closing(s),))
def estimation_error_at_closing_deg_s(run) -> float:
    """|w_hat - w| at the first sample with t >= startup_s, when control begins [deg/s]."""
    return float(run.reduced(_at_closing(run.scenario)))


@metric("estimation_error_final_deg_s", applies=_estimator_is_lebedev, uses=lambda s: (_final(s),))
def estimation_error_final_deg_s(run) -> float:
    """max |w_hat - w| over the last 10 % of the run [deg/s]."""
    return float(run.reduced(_final(run.scenario)))


def _has_continuous_reference(scenario) -> bool:
    return scenario.reference is not None and scenario.reference[0] == "lebedev_continuous"


@metric("max_deviation_from_continuous_deg_s", applies=_has_continuous_reference, uses=(OMEGA_ERROR,))
def max_deviation_from_continuous_deg_s(run) -> float:
    """max over trace samples of |w - w_c|, w_c the continuous-time closed loop (reference lebedev_continuous) [deg/s]."""
    if run.reference_error:
        raise ValueError(run.reference_error)
    return float(np.degrees(run.reduced(OMEGA_ERROR)))

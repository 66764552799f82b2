"""Run metrics by name, computed from the recorded signals after a run; checks bound them.

A metric registers with `@metric(name, applies)`, where `applies(scenario)` says whether
the metric exists for that scenario; a check naming a metric that does not exist is bad
input, caught before the run. The first line of its docstring is its one-line meaning
(`testbed describe metric NAME`, `testbed run --explain`); a metric whose value can look
alarming in a run that works as designed registers a `caveat` saying why, and `caveat_when`
(the run's metric values -> bool) says when the run's summary should print it.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np

from testbed.systems.registry import is_free_flying
from testbed.errors import InputError, described, error_line
from testbed.interrupts import from_a_signal
from testbed.recording import spectra
from testbed.recording.reductions import First, Last, MaxDistanceFromFirst, MaxNorm
from testbed.run_core.conservation import Conservation
from testbed.registry import Registry


@dataclass(frozen=True)
class Metric:
    name: str
    doc: str
    applies: Callable
    compute: Callable
    uses: tuple | Callable | None = None  # what it reads (see `metric`); None: everything
    caveat: str = ""                        # why a value that looks alarming can be by design
    caveat_when: Callable | None = None     # metric values -> whether a run's value calls for the caveat

    def used_by(self, scenario) -> tuple | None:
        """The signal keys and reductions the metric reads in `scenario` (None: every signal)."""
        return self.uses(scenario) if callable(self.uses) else self.uses


METRICS = Registry("metric")


def metric(name: str, applies: Callable = lambda scenario: True, uses=None, caveat: str = "",
           caveat_when: Callable | None = None):
    """Register `fn(run) -> float` as metric `name` (docstring = its definition; its first line
    the one-line meaning), with an optional `caveat` printed beside a value for which
    `caveat_when(values)` holds (values: the run's metrics by name; see the module doc).

    `uses` says what the metric reads, so that a run keeps no more than that: signal keys whose
    whole history it reads as `run.recorder[key]` (with `run.recorder.time`), and running
    reductions (`testbed.recording.reductions`) it reads as `run.reduced(reduction)`, which need no
    history. `uses` may be a function of the scenario giving them (a reduction built from the
    scenario's parameters, e.g. a window that ends at the planned end of the run; the metric
    builds the same one from `run.scenario` to read it). None (the default) keeps every signal
    of the run in memory."""

    def register(fn):
        declared = uses if uses is None or callable(uses) else tuple(uses)
        METRICS.add(name, Metric(name, (fn.__doc__ or "").strip().splitlines()[0], applies, fn, declared,
                                 caveat, caveat_when), fn.__module__)
        return fn

    return register


def meaning(name: str) -> str:
    """The one-line meaning of metric `name` ("" for a name no metric has, e.g. a plug-in's gone)."""
    return METRICS[name].doc if name in METRICS else ""


def caveats(values: dict[str, float]) -> dict[str, str]:
    """name -> caveat of each metric in `values` whose value calls for it (its `caveat_when`)."""
    return {name: METRICS[name].caveat for name in values
            if name in METRICS and METRICS[name].caveat_when is not None and METRICS[name].caveat_when(values)}


def available(scenario) -> list[str]:
    return [name for name, m in METRICS.items() if m.applies(scenario)]


def kept_signals(scenario) -> set[str] | None:
    """The signal keys whose history the metrics and spectra of `scenario` read (None: every signal)."""
    keys: set[str] = {key for s in spectra.available(scenario) for key in s.uses}
    for name in available(scenario):
        uses = METRICS[name].used_by(scenario)
        if uses is None:
            return None
        keys |= {u for u in uses if isinstance(u, str)}
    return keys


def reductions(scenario) -> list:
    """The running reductions the metrics of `scenario` read, each once."""
    return list(dict.fromkeys(u for name in available(scenario) for u in (METRICS[name].used_by(scenario) or ())
                              if not isinstance(u, str)))


def validate_checks(scenario, checks) -> None:
    """Refuse a check (a name of `checks`) that names no metric `scenario` produces."""
    names = available(scenario)
    for name in checks:
        if name not in names:
            raise InputError(f"checks.{name}", f"no such metric for this scenario (available: {', '.join(names)})")


def compute_all(run) -> tuple[dict[str, float], dict[str, str]]:
    """(values, why): every metric of the run; one that cannot be computed (e.g. from a run cut
    short) is NaN, with the reason in `why`, and fails any check on it."""
    values, why = {}, {}
    for name in available(run.scenario):
        try:
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # numpy's nan-reductions of an empty or all-NaN run
                values[name] = float(METRICS[name].compute(run))
        except BaseException as exc:  # a metric of a partial or odd trace; a plug-in's sys.exit too
            if from_a_signal(exc):
                raise
            values[name], why[name] = float("nan"), error_line(described(exc))
        if not np.isfinite(values[name]) and name not in why:
            why[name] = "the recorded signals give no finite value"
    return values, why


def sample_norms(run, key: str) -> np.ndarray:
    """|v| per trace sample of the recorded vector signal `key`."""
    return np.linalg.norm(run.recorder[key], axis=1)


def final_norm_metric(name: str, key: str, doc: str, applies: Callable = lambda scenario: True) -> None:
    """Register metric `name` = |v| of the recorded vector signal `key` at the last trace sample."""
    last = Last(key)

    def final_norm(run) -> float:
        return float(np.linalg.norm(run.reduced(last)))

    final_norm.__doc__ = doc
    metric(name, applies, uses=(last,))(final_norm)


def evaluate_checks(scenario, values: dict[str, float], why: dict[str, str] | None = None) -> list[dict]:
    """One row per check; a check on a metric that is not finite fails with the reason."""
    rows = []
    for name, limit in scenario.checks.items():
        value = values.get(name, float("nan"))
        row = {"name": name, "value": value, "limit": limit.text, "passed": limit.passed(value)}
        if not np.isfinite(value):
            row["reason"] = (why or {}).get(name, "the run recorded too little to compute it")
        rows.append(row)
    return rows


def value_text(value: float, limit_text: str, passed: bool, figures: int = 4) -> str:
    """A check's value as a table prints it: `figures` significant figures, more (up to 17, all a double
    holds) while the printed figure, read back, would get the other verdict against the printed limit
    (`CheckLimit.text`, `<= max and >= min`): a failing 1.0000000000000002 is never printed as 1 beside
    `<= 1`."""
    bounds = [(word, float(number)) for word, number in (part.split() for part in limit_text.split(" and "))]
    for digits in range(figures, 18):
        text = f"{value:.{digits}g}"
        shown = float(text)
        if (all(shown <= b if word == "<=" else shown >= b for word, b in bounds) and np.isfinite(shown)) == passed:
            return text
    return text


# --- metrics every free-flying system has ---------------------------------------------------

def _free_flying(scenario) -> bool:
    return is_free_flying(scenario)


def _conserves_momentum(scenario) -> bool:
    return Conservation.of(scenario).momentum


def _conserves_energy(scenario) -> bool:
    return Conservation.of(scenario).energy


MOMENTUM_DRIFT = MaxDistanceFromFirst("truth/angular_momentum_world")
ENERGY_DRIFT = MaxDistanceFromFirst("truth/kinetic_energy")
ENERGY_FIRST = First("truth/kinetic_energy")
OMEGA_ERROR = MaxNorm("reference/omega_error")


@metric("momentum_drift_rel", applies=_conserves_momentum, uses=(MOMENTUM_DRIFT,))
def momentum_drift_rel(run) -> float:
    """max |L(t) - L(0)| / L_scale of the total inertial angular momentum; L_scale = max(|L(0)|, stored rotor momentum)."""
    return float(run.reduced(MOMENTUM_DRIFT) / run.momentum_scale)


@metric("energy_drift_rel", applies=_conserves_energy, uses=(ENERGY_DRIFT, ENERGY_FIRST))
def energy_drift_rel(run) -> float:
    """max |T(t) - T(0)| / T(0) of the kinetic energy (no actuator does work, no appendage)."""
    return float(run.reduced(ENERGY_DRIFT) / max(abs(run.reduced(ENERGY_FIRST)[0]), 1e-300))


@metric("max_omega_error_rad_s", applies=lambda s: s.reference is not None, uses=(OMEGA_ERROR,))
def max_omega_error_rad_s(run) -> float:
    """max over samples of |w_truth - w_reference| (body frame) [rad/s]."""
    if run.reference_error:
        raise ValueError(run.reference_error)
    return run.reduced(OMEGA_ERROR)


final_norm_metric("final_omega_rad_s", "truth/omega", "|w| of the bus at the end of the run [rad/s].",
                  applies=_free_flying)

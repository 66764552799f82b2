"""Metrics of runs with appendages: the panels' and spring-mass slosh modes as MuJoCo gives them
(free decay of the recorded deflections, and the linearised model) against the closed forms
(closed_form.py, docs/theory/flexible.md).

The closed forms hold for a bus whose rotors hold no momentum (no gyroscopic coupling), panels
in the planar configuration of closed_form.planar_parts, spring-mass slosh without panels or
pendulums beside it; a configuration outside them, or a decay with fewer than three peaks,
gives NaN (and fails any check)."""

from __future__ import annotations

import mujoco
import numpy as np

from testbed.appendages.closed_form import Modes, RigidPart, free_free_modes, spring_mass_modes
from testbed.appendages.joints import PANEL_SIGNAL, SLOSH_OFFSET_SIGNAL, rigid_mass
from testbed.appendages.modal import free_decay, linearised_modes
from testbed.appendages.params import carries_appendages
from testbed.metrics import metric
from testbed.systems.free_bus import BUS_BODY
from testbed.systems.registry import make_plant

PANEL_KEY, SLOSH_KEY = f"truth/{PANEL_SIGNAL}", f"truth/{SLOSH_OFFSET_SIGNAL}"


def _appendages(scenario):
    return scenario.model.appendages if carries_appendages(scenario.system) else None


def _wings(scenario) -> bool:
    appendages = _appendages(scenario)
    return appendages is not None and bool(appendages.wings)


def _panel_decay(scenario) -> bool:
    """Wings, the first panel let go deflected: a free decay to read."""
    return _wings(scenario) and scenario.model.appendages.wings[0].panels[0].initial_angle_deg != 0.0


def _damped_panel_decay(scenario) -> bool:
    return _panel_decay(scenario) and scenario.model.appendages.wings[0].panels[0].damping_nms_rad > 0.0


def _spring_mass_decay(scenario) -> bool:
    """Spring-mass slosh alone (no wings, no pendulum), the first let go off its rest point."""
    appendages = _appendages(scenario)
    return (appendages is not None and bool(appendages.slosh) and not appendages.wings
            and all(s.model == "spring_mass" for s in appendages.slosh) and any(appendages.slosh[0].offsets()))


def _rigid(run) -> RigidPart:
    """The bus and everything on it but the appendages, from the compiled model at rest."""
    def compute():
        model = make_plant(run.scenario).model
        return RigidPart(*rigid_mass(model, model.body(BUS_BODY).id))
    return run.shared("appendages:rigid", compute)


def _closed_form(run, modes) -> Modes | None:
    try:
        return modes(_rigid(run), run)
    except ValueError:  # not the planar configuration the closed form holds for
        return None


def _decay_against(run, key: str, modes) -> tuple[float, float]:
    """(relative frequency error, relative damping-ratio error) of the free decay of column 0 of
    signal `key` against the closed-form mode nearest its frequency."""
    def compute():
        expected = _closed_form(run, modes)
        if expected is None or not len(expected.frequency):
            return float("nan"), float("nan")
        try:
            frequency, zeta = free_decay(run.recorder.time, run.recorder[key][:, 0])
        except ValueError:  # fewer than three peaks: too short a run, or overdamped
            return float("nan"), float("nan")
        nearest = int(np.argmin(np.abs(expected.frequency - frequency)))
        zeta_error = abs(zeta - expected.damping_ratio[nearest]) / expected.damping_ratio[nearest] \
            if expected.damping_ratio[nearest] > 0 else float("nan")
        return abs(frequency - expected.frequency[nearest]) / expected.frequency[nearest], zeta_error
    return run.shared(f"appendages:decay:{key}", compute)


def _panel_modes(rigid, run) -> Modes:
    return free_free_modes(rigid, run.scenario.model.appendages.wings)


def _slosh_modes(rigid, run) -> Modes:
    return spring_mass_modes(rigid, run.scenario.model.appendages.slosh)


@metric("panel_frequency_error_rel", applies=_panel_decay, uses=(PANEL_KEY,))
def panel_frequency_error_rel(run) -> float:
    """|w - w_cf| / w_cf: the first panel's free-decay frequency (its peaks) against the nearest
    closed-form free-free mode of bus plus panels (docs/theory/flexible.md)."""
    return _decay_against(run, PANEL_KEY, _panel_modes)[0]


@metric("panel_damping_ratio_error_rel", applies=_damped_panel_decay, uses=(PANEL_KEY,))
def panel_damping_ratio_error_rel(run) -> float:
    """|zeta - zeta_cf| / zeta_cf: the first panel's log-decrement damping ratio against the closed
    form's for that mode."""
    return _decay_against(run, PANEL_KEY, _panel_modes)[1]


@metric("panel_linearised_frequency_error_rel", applies=_panel_decay, uses=())
def panel_linearised_frequency_error_rel(run) -> float:
    """max over the closed-form free-free modes of |w_lin - w_cf| / w_cf, w_lin the nearest mode of
    MuJoCo's linearised model at rest (mjd_transitionFD; a servo's or rotor's modes lie beside them)."""
    expected = _closed_form(run, _panel_modes)
    if expected is None:
        return float("nan")
    model = make_plant(run.scenario).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    found = linearised_modes(model, data).frequency
    if not len(found):
        return float("nan")
    nearest = found[np.argmin(np.abs(found[None, :] - expected.frequency[:, None]), axis=1)]
    return float(np.max(np.abs(nearest - expected.frequency) / expected.frequency))


@metric("slosh_frequency_error_rel", applies=_spring_mass_decay, uses=(SLOSH_KEY,))
def slosh_frequency_error_rel(run) -> float:
    """|w - w_cf| / w_cf: the first spring-mass slide's free-decay frequency against the nearest
    closed-form mode of bus plus slosh masses (docs/theory/flexible.md)."""
    return _decay_against(run, SLOSH_KEY, _slosh_modes)[0]


@metric("slosh_damping_ratio_error_rel", applies=lambda s: _spring_mass_decay(s) and s.model.appendages.slosh[0].damping_ratio > 0,
        uses=(SLOSH_KEY,))
def slosh_damping_ratio_error_rel(run) -> float:
    """|zeta - zeta_cf| / zeta_cf: the first spring-mass slide's log-decrement damping ratio against
    the closed form's for that mode."""
    return _decay_against(run, SLOSH_KEY, _slosh_modes)[1]

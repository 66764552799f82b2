"""Metrics of a planar AKOR run: figures measured in simulation vs Avdeev & Kaptsova 2016.

A planar run (model.system planar, law akor_lqr) has up to three phases, set by the
disturbance switch-on times of the model (model.py):
1. free decay from x(0) = (x10, x20) until the first switch-on: the closed-loop poles
   (eta), the settling time and the actuator power;
2. a constant m0 from `disturbance_start_s`: the static error, ER0;
3. a ramp m0' (t - t_ramp) from `ramp_start_s` to the end: ER1.
A metric exists only when its phase does (so a check on it is refused otherwise).
Measured values come from the recorded truth (figures.py); each is compared
with the paper's formula from akor_regulator.py.
"""

from __future__ import annotations

import numpy as np

from testbed.metrics import metric
from testbed.systems.planar import akor_regulator as ak
from testbed.systems.planar import figures as fig


# --- which phases a scenario has ---------------------------------------------------------

def _is_akor(s) -> bool:
    return s.system == "planar" and s.stages["law"][0] == "akor_lqr"


def _first_switch_on(s) -> float:
    events = s.model.events()
    return events[0][0] if events else s.sim.duration_s


def _has_decay(s) -> bool:
    return _is_akor(s) and _first_switch_on(s) > 0 and (s.model.initial_angle_rad or s.model.initial_rate_rad_s)


def _has_offset_decay(s) -> bool:
    """Free decay from x(0) = (x10, 0): the case the settling time and eq. 18-20 describe."""
    return _has_decay(s) and s.model.initial_angle_rad != 0 and s.model.initial_rate_rad_s == 0


def _has_constant(s) -> bool:
    m = s.model
    if not (_is_akor(s) and m.disturbance_rad_s2):
        return False
    end = m.ramp_start_s if m.disturbance_rate_rad_s3 else s.sim.duration_s
    return end > m.disturbance_start_s


def _has_ramp(s) -> bool:
    m = s.model
    return (_is_akor(s) and bool(m.disturbance_rate_rad_s3) and m.ramp_start_s < s.sim.duration_s
            and (not m.disturbance_rad_s2 or m.disturbance_start_s <= m.ramp_start_s))


# the figures (pole fit, settling time, steady lines, power peak) read these signals' history
TRUTH = ("truth/angle", "truth/rate", "truth/control_torque")


def _weights(run):
    p = run.scenario.stages["law"][1]
    return p.beta11, p.beta22, p.k


def _window(run, t0: float, t1: float):
    """Recorded (t, x) with t0 <= t <= t1, x = (angle, rate) from the truth."""
    rec = run.recorder
    t = rec.time
    keep = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
    x = np.column_stack([rec["truth/angle"][:, 0], rec["truth/rate"][:, 0]])
    return t[keep], x[keep]


def _cached(run, key, compute, failed=float("nan")):
    """compute() once per run; `failed` (NaN) when the recorded window cannot give it (e.g. a
    diverged run cut short), so its checks fail instead of the run raising."""
    def guarded():
        try:
            with np.errstate(all="ignore"):
                return compute()
        except (ValueError, IndexError, np.linalg.LinAlgError):
            return failed

    return run.shared(f"planar/{key}", guarded)


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


# --- the design itself --------------------------------------------------------------------

@metric("akor_root_kind", applies=_is_akor, uses=())
def root_kind(run) -> float:
    """+1 real, 0 double, -1 complex closed-loop roots (eq. 11: sign of b22 sqrt(k) - 2 sqrt(b11))."""
    b11, b22, k = _weights(run)
    return float(np.sign(b22 * np.sqrt(k) - 2.0 * np.sqrt(b11)))


@metric("akor_eta_formula_1_s", applies=_is_akor, uses=())
def eta_formula(run) -> float:
    """Stability margin eta from eq. 12 (real roots) or eq. 13 (double, complex) [1/s]."""
    return float(ak.stability_margin(*_weights(run)))


# --- phase 1: free decay ------------------------------------------------------------------

def _decay_figure(run, key: str, figure):
    """figure(t, x) of the free-decay phase (from t = 0 to the first switch-on), once per run."""
    t, x = _window(run, 0.0, _first_switch_on(run.scenario))
    return _cached(run, key, lambda: figure(t, x))


def _eta_sim(run) -> float:
    return _decay_figure(run, "eta", lambda t, x: fig.stability_margin_from_poles(fig.identify_poles(t, x)))


@metric("akor_eta_sim_1_s", applies=_has_decay, uses=TRUTH)
def eta_sim(run) -> float:
    """Stability margin from the simulated free decay: poles of a transition matrix fitted to it [1/s]."""
    return _eta_sim(run)


@metric("akor_eta_rel_err", applies=_has_decay, uses=TRUTH)
def eta_rel_err(run) -> float:
    """|eta_sim - eta(eq. 12/13)| / eta(eq. 12/13)."""
    return abs(_eta_sim(run) - eta_formula(run)) / eta_formula(run)


@metric("akor_eta_over_eta_max", applies=_has_decay, uses=TRUTH)
def eta_over_eta_max(run) -> float:
    """eta_sim / (k b11)^(1/4): at most 1, equal to 1 at the double root (eq. 17)."""
    b11, _, k = _weights(run)
    return _eta_sim(run) / ak.eta_max(b11, k)


def _settling_sim(run) -> float:
    return _decay_figure(run, "settling", lambda t, x: fig.settling_time(t, x[:, 0], final=0.0))


@metric("akor_settling_time_s", applies=_has_offset_decay, uses=TRUTH)
def settling_time_s(run) -> float:
    """Simulated 95 % settling time: last time |angle| > 5 % of x10 (definition before Fig. 2) [s]."""
    return _settling_sim(run)


@metric("akor_settling_time_rel_err", applies=_has_offset_decay, uses=TRUTH)
def settling_time_rel_err(run) -> float:
    """|Tp_sim - Tp_exact| / Tp_exact, Tp_exact from the exact closed-loop response."""
    exact = ak.settling_time_95(*_weights(run))
    return abs(_settling_sim(run) - exact) / exact


@metric("akor_settling_rule_error_rel", applies=_has_offset_decay, uses=TRUTH)
def settling_rule_error_rel(run) -> float:
    """(3/eta - Tp_sim) / Tp_sim: the paper's rule Tp ~ 3/eta, claimed within +-35 %."""
    rule = ak.settling_time_estimate(eta_formula(run))
    return (rule - _settling_sim(run)) / _settling_sim(run)


def _power_peak(run) -> float:
    def compute():
        t1 = _first_switch_on(run.scenario)
        rec = run.recorder
        keep = rec.time <= t1 + 1e-9
        J = run.description["hinge_inertia_kg_m2"]
        P = rec["truth/control_torque"][keep, 0] / J * rec["truth/rate"][keep, 0]
        return fig.peak(rec.time[keep], P)[1] / run.scenario.model.initial_angle_rad ** 2
    return _cached(run, "power", compute)


@metric("akor_power_peak_per_x10sq", applies=_has_offset_decay, uses=TRUTH)
def power_peak_per_x10sq(run) -> float:
    """Simulated peak actuator power per unit inertia and unit offset, max (tau/J) x2 / x10^2 [1/s^3]."""
    return _power_peak(run)


@metric("akor_power_peak_rel_err", applies=_has_offset_decay, uses=TRUTH)
def power_peak_rel_err(run) -> float:
    """|P_peak,sim - P_peak| / P_peak, P_peak from eq. 20 (complex roots) or eq. 18 on the exact response."""
    return abs(_power_peak(run) - ak.peak_power(*_weights(run), 1.0)[1]) / ak.peak_power(*_weights(run), 1.0)[1]


# --- phase 2: constant disturbance ----------------------------------------------------------

def _er0_sim(run) -> np.ndarray:
    def compute():
        m = run.scenario.model
        end = m.ramp_start_s if m.disturbance_rate_rad_s3 else run.scenario.sim.duration_s
        t, x = _window(run, m.disturbance_start_s, end)
        value, _ = fig.steady_line(t, x)
        return value / m.disturbance_rad_s2
    return _cached(run, "er0", compute, failed=np.full(2, np.nan))


@metric("akor_static_angle_error_rad", applies=_has_constant, uses=TRUTH)
def static_angle_error_rad(run) -> float:
    """Simulated steady angle under the constant m0 [rad]."""
    return float(_er0_sim(run)[0] * run.scenario.model.disturbance_rad_s2)


@metric("akor_static_angle_error_rel_err", applies=_has_constant, uses=TRUTH)
def static_angle_error_rel_err(run) -> float:
    """|dphi_sim - m0/sqrt(k b11)| / |m0/sqrt(k b11)| (text of eq. 17)."""
    b11, _, k = _weights(run)
    ref = ak.static_angle_error(b11, k, run.scenario.model.disturbance_rad_s2)
    return abs(static_angle_error_rad(run) - ref) / abs(ref)


@metric("akor_er0_rel_err", applies=_has_constant, uses=TRUTH)
def er0_rel_err(run) -> float:
    """|ER0_sim - ER0| / |ER0|, ER0 = -(a*)^-1 c (eq. 15), both components."""
    return _rel(_er0_sim(run), ak.error_coefficients(*_weights(run))[0])


@metric("akor_eta_max_from_static_error_rel_err", applies=_has_constant, uses=TRUTH)
def eta_max_from_static_error_rel_err(run) -> float:
    """|sqrt(m0/dphi_sim) - (k b11)^(1/4)| / (k b11)^(1/4) (eq. 17)."""
    b11, _, k = _weights(run)
    eta = np.sqrt(run.scenario.model.disturbance_rad_s2 / static_angle_error_rad(run))
    return abs(eta - ak.eta_max(b11, k)) / ak.eta_max(b11, k)


# --- phase 3: ramp ------------------------------------------------------------------------

def _er1_sim(run) -> np.ndarray:
    """ER1 from the steady line x = p + q t at the end of the ramp: ER0 = q/m0',
    ER1 = (x_end - ER0 m(t_end)) / m0' (eq. 14-15), all from the simulation."""
    def compute():
        m, end = run.scenario.model, run.scenario.sim.duration_s
        t, x = _window(run, m.ramp_start_s, end)
        value, slope = fig.steady_line(t, x)
        er0 = slope / m.disturbance_rate_rad_s3
        return (value - er0 * m.disturbance(t[-1])) / m.disturbance_rate_rad_s3
    return _cached(run, "er1", compute, failed=np.full(2, np.nan))


@metric("akor_er1_angle_sim", applies=_has_ramp, uses=TRUTH)
def er1_angle_sim(run) -> float:
    """ER1[0] measured under the ramp [s^2]."""
    return float(_er1_sim(run)[0])


@metric("akor_er1_rate_sim", applies=_has_ramp, uses=TRUTH)
def er1_rate_sim(run) -> float:
    """ER1[1] measured under the ramp [s]."""
    return float(_er1_sim(run)[1])


@metric("akor_er1_rel_err", applies=_has_ramp, uses=TRUTH)
def er1_rel_err(run) -> float:
    """|ER1_sim - ER1| / |ER1|, ER1 = -(a*)^-2 c (eq. 15), both components."""
    return _rel(_er1_sim(run), ak.error_coefficients(*_weights(run))[1])


@metric("akor_eq16_er1_rel_err", applies=_has_ramp, uses=TRUTH)
def eq16_er1_rel_err(run) -> float:
    """|ER1_sim - ER1(eq. 16 as printed)| / |ER1_sim|: large when the printed sign is wrong."""
    printed = ak.error_coefficients_as_printed(*_weights(run))[1]
    return _rel(printed, _er1_sim(run))


@metric("akor_eq16_er1_sign_matches", applies=_has_ramp, uses=TRUTH)
def eq16_er1_sign_matches(run) -> float:
    """1 if the printed eq. 16 has the simulated sign of ER1[0], else 0."""
    printed = ak.error_coefficients_as_printed(*_weights(run))[1]
    return float(np.sign(printed[0]) == np.sign(_er1_sim(run)[0]))

"""Fault detection and isolation of the steered units, from their own read-outs.

At control tick k the steering compares what each unit does with what it was told
(docs/theory/faults.md, "Detection and isolation"):

    gimbal rate   r_i = |b'_i(t_k) - c_i(k-1)|       over  a + rho |c_i(k-1)|
    rotor speed   s_i = |W_i(t_k) - W_cmd| / W_nom    over  sigma

b'_i the tachometer's rate at the end of the tick the command c_i(k-1) was held over (a servo
that follows its command ends the tick on it), W_i the rotor tachometer, W_cmd the speed
commanded over that tick (the nominal W_nom for fixed-speed rotors). A unit whose residual stays over its threshold for `persistence` consecutive ticks is
declared failed at that tick; from then on the steering runs on the other units' columns of J
(the failed unit's column is zeroed and its command pinned at 0: stage.py). The relative part
rho keeps a unit whose command is large but well followed from tripping on the servo's
transient; a stuck gimbal (b' = 0) trips once |c_i| > a / (1 - rho). At most
`max_failed_units` are dropped (a cluster needs three units for rank 3).
"""

from __future__ import annotations

import numpy as np


class FaultIsolation:
    """The residual tests of the module doc over `units` units; `failed` the units dropped (0-based).

    params: the steering's fault_rate_residual_deg_s (a), fault_rate_residual_rel (rho),
    fault_speed_residual_rel (sigma), fault_persistence and max_failed_units (stage.py)."""

    def __init__(self, params, units: int, nominal_speed: float | None):
        self.rate_floor = np.radians(params.fault_rate_residual_deg_s)
        self.rate_share = params.fault_rate_residual_rel
        self.speed_share = params.fault_speed_residual_rel
        self.persistence = params.fault_persistence
        self.max_failed = min(params.max_failed_units, max(units - 3, 0))
        self.nominal_speed = nominal_speed
        self.count = np.zeros(units, int)
        self.failed: list[int] = []
        self.first_over = np.full(units, np.nan)  # time each unit's current run over threshold began
        self.statistics = {"isolated_unit": 0.0, "isolation_time": np.nan, "detection_time": np.nan}

    @property
    def healthy(self) -> np.ndarray:
        mask = np.ones(len(self.count), bool)
        mask[self.failed] = False
        return mask

    def residuals(self, commanded, actuators, speeds=None) -> np.ndarray:
        """Each unit's largest residual over its threshold (> 1: over), (units,); `speeds`: the rotor
        speeds commanded over the last tick (variable-speed rotors), else the nominal one."""
        rate = np.asarray(actuators["gimbal_rate"], float)
        commanded = np.asarray(commanded, float)
        ratio = np.abs(rate - commanded) / (self.rate_floor + self.rate_share * np.abs(commanded))
        if self.nominal_speed and "rotor_rate" in actuators:
            wanted = self.nominal_speed if speeds is None else np.asarray(speeds, float)
            speed = np.abs(np.asarray(actuators["rotor_rate"], float) - wanted) / abs(self.nominal_speed)
            ratio = np.maximum(ratio, speed / self.speed_share)
        return ratio

    def update(self, t: float, commanded, actuators, speeds=None) -> np.ndarray:
        """One tick's test of the command held until now against the read-outs at t [s]; returns
        the residual ratios (recorded as `allocator/fault_residual`)."""
        ratio = self.residuals(commanded, actuators, speeds)
        over = ratio > 1.0
        self.first_over[over & (self.count == 0)] = t
        self.count = np.where(over, self.count + 1, 0)
        for i in np.flatnonzero(self.count >= self.persistence):
            if i not in self.failed and len(self.failed) < self.max_failed:
                self.failed.append(int(i))
                if len(self.failed) == 1:
                    self.statistics.update(isolated_unit=float(i + 1), isolation_time=t,
                                           detection_time=float(self.first_over[i]))
        return ratio

"""A run's clock: the physics step, the stages' periods and the whole counts between them.

Read once from the scenario's validated `sim:` block (`SimConfig.validate` refuses periods that
are not whole multiples of each other); every part of a run takes its dt and its counts from here.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Timing:
    """The periods [s] of a run and the whole numbers of one in another.

    A control tick (law and allocator) is `samples_per_tick` sensor samples; a sample is
    `steps_per_sample` physics steps of `dt_s`; a trace sample is taken every `trace_every` loop
    steps (ticks when the stages share one rate, sensor samples otherwise); the `.rrd` holds
    envelopes of `envelope_rows` trace samples (1: every sample)."""

    dt_s: float
    control_period_s: float
    sample_period_s: float
    trace_period_s: float
    n_ticks: int
    steps_per_tick: int
    steps_per_sample: int
    samples_per_tick: int
    trace_every: int
    envelope_rows: int

    @classmethod
    def of(cls, sim) -> "Timing":
        """The timing of a validated `SimConfig` (its ratios are whole: rounding only removes round-off)."""
        samples_per_tick = round(sim.control_period_s / sim.estimator_period_s)
        loop_period = sim.control_period_s if samples_per_tick == 1 else sim.estimator_period_s
        return cls(dt_s=sim.dt_s, control_period_s=sim.control_period_s, sample_period_s=sim.estimator_period_s,
                   trace_period_s=sim.trace_period_s, n_ticks=round(sim.duration_s / sim.control_period_s),
                   steps_per_tick=round(sim.control_period_s / sim.dt_s),
                   steps_per_sample=round(sim.estimator_period_s / sim.dt_s), samples_per_tick=samples_per_tick,
                   trace_every=round(sim.trace_period_s / loop_period),
                   envelope_rows=(1 if sim.trace_envelope_s is None
                                  else round(sim.trace_envelope_s / sim.trace_period_s)))

    @property
    def multirate(self) -> bool:
        """Whether the sensor and estimator run at a shorter period than the law and allocator."""
        return self.samples_per_tick > 1

    @property
    def loop_steps(self) -> int:
        """Steps of the run loop: control ticks, or sensor samples when the rates differ."""
        return self.n_ticks * self.samples_per_tick

    def time_after(self, ticks: int) -> float:
        """The time [s] after `ticks` control periods, on the loop's grid exactly (k Tc, or k m Ts
        with m samples a tick: the product the loop itself forms, so that the two agree to the bit)."""
        if self.samples_per_tick == 1:
            return ticks * self.control_period_s
        return ticks * self.samples_per_tick * self.sample_period_s

    @property
    def end_time_s(self) -> float:
        """Time of the run's last trace sample, the final state [s]: after all n_ticks ticks."""
        return self.time_after(self.n_ticks)

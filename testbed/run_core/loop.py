"""The run loop: control ticks, each the pipeline on the state at t then the physics to t + Tc.

Per control tick k (t = k Tc): record the truth (at the trace period), run the pipeline on
the state at t, hold its command (zero-order hold) for the Tc / dt physics steps to t + Tc.
With a sensor and estimator faster than the law (`Timing.multirate`) the loop steps their samples.
"""

from __future__ import annotations

import functools

from testbed.run_core.stage_contract import StageFailed


# Ticks between two looks for a bad state (Plant.check_state): a divergence is reported
# within this many ticks of where it happened, and the look costs a tenth of its price a tick.
CHECK_EVERY_TICKS = 10


def loop_of(timing):
    """The loop that runs `timing`'s steps: `run_ticks` at one rate, else `run_samples`."""
    return run_samples if timing.multirate else run_ticks


def run_ticks(plant, pipeline, recorder, start: int, stop: int, timing, progress=None) -> None:
    """Ticks k = start .. stop - 1 of the run's `timing.n_ticks`: the pipeline at t = k Tc, a
    trace sample of the stages' outputs and the truth every `timing.trace_every` ticks, then
    Tc / dt physics steps; `progress(fraction)` about 200 times a run.

    The ticks run in blocks that start at a trace sample (`block_ticks`; a range that starts
    between two is first run to the next block's start); the plant is checked for a bad state
    at the end of each block, and before a stage's failure is reported (a state MuJoCo reset
    may be what the stage failed on)."""
    steps, tc, trace_every, n_ticks = timing.steps_per_tick, timing.control_period_s, timing.trace_every, timing.n_ticks
    block = block_ticks(trace_every, CHECK_EVERY_TICKS)
    report_every = max(1, n_ticks // 200)
    next_report = start
    tick, advance, check = pipeline.tick, plant.stepper(steps), plant.check_state
    first = start
    while first < stop:
        last = min(first + block - first % block, stop)  # the end of the block `first` is in
        t0 = first * tc
        k = first
        try:
            tick(t0, plant)
            if first % trace_every == 0:
                signals = pipeline.signals()
                signals["truth"] = plant.truth()
                recorder.sample(t0, signals)
            advance()
            for k in range(first + 1, last):
                tick(k * tc, plant)
                advance()
        except (StageFailed, FloatingPointError):
            check(t0, (k - first) * steps)
            raise
        check(t0, (k + 1 - first) * steps)
        if progress is not None and first >= next_report:
            progress(first / n_ticks)
            next_report = first + report_every
        first = last


@functools.lru_cache(maxsize=64)  # a stepped run asks at every period
def block_ticks(trace_every: int, longest: int) -> int:
    """The largest number of ticks <= `longest` that divides `trace_every`: blocks of it
    start at every trace sample."""
    return max(n for n in range(1, min(trace_every, longest) + 1) if trace_every % n == 0)


def run_samples(plant, pipeline, recorder, start: int, stop: int, timing, progress=None) -> None:
    """Samples j = start .. stop - 1 of the run's `timing.loop_steps` (t = j Ts, Ts =
    timing.sample_period_s): the sensor and the estimator, and at every control instant (each
    `samples_per_tick`-th sample) the whole pipeline, whose command stays held over the control
    period; Ts / dt physics steps. A trace sample every `trace_every` samples holds the truth
    and the stages that ran at it: sensor and estimator at their rate, law and allocator only
    at control instants (each stage at its own rate)."""
    per_tick, steps, ts = timing.samples_per_tick, timing.steps_per_sample, timing.sample_period_s
    trace_every, n_samples = timing.trace_every, timing.loop_steps
    report_every = max(1, n_samples // 200)
    tick, sense, step = pipeline.tick, pipeline.sense, plant.step
    for j in range(start, stop):
        t = j * ts
        control = j % per_tick == 0
        if control:
            tick(t, plant)
        else:
            sense(t, plant)
        if j % trace_every == 0:
            signals = pipeline.signals() if control else pipeline.sensed_signals()
            signals["truth"] = plant.truth()
            recorder.sample(t, signals)
        step(steps)
        if progress is not None and j % report_every == 0:
            progress(j / n_samples)

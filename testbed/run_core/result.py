"""What a run gives: `RunResult` (status, metrics, checks, trace) and `RunData`, what its
metrics read after the run."""

from __future__ import annotations

from dataclasses import dataclass, field

from testbed.recording.recorder import Recorder, Trace
from testbed.recording.reductions import Reductions


@dataclass
class RunData:
    """What metrics see after a run: the scenario, the trace, each stage's declared
    statistics (slot -> counts over every control step, e.g. the steering extremes) and
    the plant's static design data (`Plant.description`)."""

    scenario: object
    recorder: Recorder
    statistics: dict
    description: object
    momentum_scale: float
    reference_error: str | None = None  # why the reference signals are missing, if they are
    # figures derived from the trace that several metrics share (see `shared`)
    _shared: dict = field(default_factory=dict)
    reductions: Reductions = field(default_factory=Reductions)  # the running reductions the metrics declared

    def reduced(self, reduction):
        """The value of a running reduction a metric declared (`testbed.metrics.metric(uses=)`)."""
        return self.reductions.value(reduction)

    def shared(self, key: str, compute):
        """compute() once per run for metrics that share an expensive derived figure."""
        if key not in self._shared:
            self._shared[key] = compute()
        return self._shared[key]


# what a run ended as (RunResult.status)
STATUSES = ("ok", "diverged", "method_failed", "error")


@dataclass
class RunResult:
    """The outcome of a run (or of an `.rrd` read back): status, metrics, checks and the trace.

    status: "ok", "diverged" (MuJoCo hit a bad state), "method_failed" (a stage's method left
    the conditions it is valid in: testbed.run_core.stage_contract.MethodFailed) or "error" (a stage raised or
    returned bad output); error: the one-line reason, else None; metrics: name -> value; checks: one
    dict per check (name, value, limit, passed); trace: every recorded signal as numpy arrays
    (`result.trace["truth/omega"] -> (t, values)`); data: what the metrics saw (kept on request).
    """

    scenario: str
    sim_s: float
    wall_s: float
    status: str
    error: str | None
    metrics: dict[str, float]
    checks: list[dict]
    rrd: str | None
    data: RunData | None = None
    trace: Trace | None = None

    @property
    def passed(self) -> bool:
        return self.status == "ok" and all(c["passed"] for c in self.checks)

    def as_json(self) -> dict:
        return {"scenario": self.scenario, "sim_s": self.sim_s, "wall_s": self.wall_s,
                "status": self.status, "error": self.error, "metrics": self.metrics,
                "checks": self.checks, "rrd": self.rrd}

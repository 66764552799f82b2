"""One control tick: the four stages in order, their command handed to the plant."""

from __future__ import annotations

import numpy as np

from testbed.errors import described, refused_as
from testbed.interrupts import from_a_signal
from testbed.run_core.output_check import INTERFACE_SHAPES, OutputCheck
from testbed.run_core.stage_contract import SLOTS, Declared, MethodFailed, StageContext, StageFailed
from testbed.run_core.stage_registry import build


def _is_builtin(stage_object) -> bool:
    return type(stage_object).__module__.startswith("testbed.")




def stage_failure(t: float, slot: str, stage_object, exc: Exception) -> StageFailed:
    """The StageFailed that `exc`, raised at t [s] by `stage_object` in `slot`, ends a run with:
    its method's own limit (MethodFailed, status method_failed) or the stage's failure."""
    name = Declared.of(stage_object).type_name or type(stage_object).__name__
    if isinstance(exc, MethodFailed):
        return StageFailed(t, slot, name, exc.reason, method=True)
    return StageFailed(t, slot, name, described(exc))


class Pipeline:
    """One control tick: run the four stages in order and hand the command to the plant.

    A stage that raises (anything but Ctrl-C or SIGTERM arriving: sys.exit and os._exit too,
    testbed.exit_guard), or a plug-in stage whose output fails its `OutputCheck`, stops the
    run with `StageFailed` naming the stage, the time and the reason. The tick builds
    nothing it does not need: a built-in empty slot (`none`, which returns nothing) is not
    called, a built-in stage's output is not checked, and the outputs stay where the stages
    left them (`measurement`, `estimate`, `demand`, `command`) until `signals()` gathers
    them for a trace sample. When the allocator is the only stage that runs (an open-loop
    command), `tick` is `_allocate`, which asks nothing of the empty slots. `declared`: slot ->
    what the stage in it declares (testbed.run_core.stage_contract.Declared)."""

    def __init__(self, sensor, estimator, law, allocator, checks: dict | None = None):
        self.sensor, self.estimator, self.law, self.allocator = sensor, estimator, law, allocator
        self.measurement: dict[str, np.ndarray] = {}
        self.estimate: dict[str, np.ndarray] = {}
        self.demand: dict[str, np.ndarray] = {}
        self.command: dict[str, np.ndarray] = {}
        self.checks = dict(checks or {})
        self.declared = {slot: Declared.of(stage_object) for slot, stage_object in self.stages().items()}
        self._wire()

    def _wire(self) -> None:
        """Which stages the tick calls and checks, from the stages (`declared`) and checks now in place."""
        # open-loop allocators ignore the actuator read-outs: skip reading them
        self._needs_actuators = self.declared["allocator"].needs_actuators
        # a law that compensates w x H itself reads the internal momentum (testbed.attitude_laws.momentum_input)
        self._law_reads_momentum = "internal_momentum" in self.declared["law"].inputs
        # a built-in empty slot, which always returns nothing, is not called
        declared, checks = self.declared, self.checks
        self._sensing = not (declared["sensor"].returns_nothing and _is_builtin(self.sensor))
        self._estimating = not (declared["estimator"].returns_nothing and _is_builtin(self.estimator))
        self._controlling = not (declared["law"].returns_nothing and _is_builtin(self.law))
        self._allocating = not (declared["allocator"].returns_nothing and _is_builtin(self.allocator))
        self._sensor_check, self._estimator_check = checks.get("sensor"), checks.get("estimator")
        self._law_check, self._allocator_check = checks.get("law"), checks.get("allocator")
        self.__dict__.pop("tick", None)
        if self._allocating and not (self._sensing or self._estimating or self._controlling):
            self.tick = self._allocate  # an open-loop command: the allocator alone

    def set_stage(self, slot: str, stage_object, check: "OutputCheck | None",
                  declared: Declared | None = None) -> None:
        """Put `stage_object` in `slot`, its output checked by `check` at every tick (None: not
        checked), in place of the stage there (testbed.stepping: a Python object as a stage, or
        a command given for one step); `declared`: its declarations, if read already."""
        setattr(self, slot, stage_object)
        self.declared[slot] = Declared.of(stage_object) if declared is None else declared
        self.checks.pop(slot, None)
        if check is not None:
            self.checks[slot] = check
        self._wire()

    @classmethod
    def from_config(cls, configs: dict, ctx: StageContext, actuators: dict | None = None) -> "Pipeline":
        """The four stages of `configs` (slot -> (name, params)); plug-in stages get an
        `OutputCheck` (an allocator's command keys take their shapes from `actuators`)."""
        stages = []
        for slot in SLOTS:
            # a slot is built from its own parameters and what the others publish (ctx.stages)
            with refused_as(f"pipeline.{slot}", configs[slot][0], {f"pipeline.{s}": configs[s][1] for s in SLOTS}):
                stages.append(build(slot, *configs[slot], ctx))
        checks = {}
        for slot, stage_object in zip(SLOTS, stages):
            if _is_builtin(stage_object):
                continue
            name = configs[slot][0]
            required = ctx.stages[slot].outputs if slot in ctx.stages else ()
            output = Declared.of(stage_object).output
            shapes = dict(INTERFACE_SHAPES.get(slot, {}))
            if slot == "allocator" and output is not None:
                required = tuple(required) + (output,)
                shapes[output] = (actuators or {}).get(output)
                shapes = {k: v for k, v in shapes.items() if v is not None}
            checks[slot] = OutputCheck(slot, name, required, shapes)
        return cls(*stages, checks=checks)

    def stages(self) -> dict:
        return dict(zip(SLOTS, (self.sensor, self.estimator, self.law, self.allocator)))

    def tick(self, t: float, plant) -> None:
        """Sensor, estimator, law and allocator at time t, then the command to the plant."""
        self.sense(t, plant)
        slot = "law"
        try:
            if self._controlling:
                given = self.estimate
                if self._law_reads_momentum:
                    given = given | {"internal_momentum": plant.internal_momentum_body()}
                self.demand = self.law.torque(t, given)
                if self._law_check is not None:
                    self._law_check(t, self.demand)
            slot = "allocator"
            if self._allocating:
                actuators = plant.actuator_state() if self._needs_actuators else {}
                self.command = self.allocator.allocate(t, self.demand, self.estimate, actuators)
                if self._allocator_check is not None:
                    self._allocator_check(t, self.command)
            plant.apply(self.command)
        except BaseException as exc:
            self._raise_failure(t, slot, exc)

    def _allocate(self, t: float, plant) -> None:
        """`tick` when the allocator is the only stage that runs: the same, with nothing to skip."""
        try:
            self.command = self.allocator.allocate(t, self.demand, self.estimate,
                                                   plant.actuator_state() if self._needs_actuators else {})
            if self._allocator_check is not None:
                self._allocator_check(t, self.command)
            plant.apply(self.command)
        except BaseException as exc:
            self._raise_failure(t, "allocator", exc)

    def _raise_failure(self, t: float, slot: str, exc: BaseException):
        """Raise what the run sees of `exc`, raised at t while the stage in `slot` ran: a stage's own
        failure (sys.exit too) as StageFailed naming it, with the trace so far kept; StageFailed
        (an output check's) and a signal's stop as they are."""
        if isinstance(exc, StageFailed) or from_a_signal(exc):
            raise exc
        raise stage_failure(t, slot, self.stages()[slot], exc) from exc

    def sense(self, t: float, plant) -> None:
        """Sensor and estimator at time t: the first half of `tick`, and alone a sample between
        two control instants when they run faster than the law (`sim.estimator_period_s`),
        the command staying held."""
        slot = "sensor"
        try:
            if self._sensing:
                self.measurement = self.sensor.measure(t, plant)
                if self._sensor_check is not None:
                    self._sensor_check(t, self.measurement)
            slot = "estimator"
            if self._estimating:
                self.estimate = self.estimator.estimate(t, self.measurement, self.command)
                if self._estimator_check is not None:
                    self._estimator_check(t, self.estimate)
        except BaseException as exc:
            self._raise_failure(t, slot, exc)

    # --- one slot at a time, for a world of a batch (testbed.batch.stage_forms.PerWorld) ---------
    def run_sensor(self, t: float, plant) -> dict:
        """The sensor's measurement at t, checked as in `tick` ({} from a built-in empty slot)."""
        return self._checked("sensor", t, self._sensing, lambda: self.sensor.measure(t, plant), self._sensor_check)

    def run_estimator(self, t: float, measurement: dict, command: dict) -> dict:
        """The estimator's output at t, checked as in `tick`."""
        return self._checked("estimator", t, self._estimating,
                             lambda: self.estimator.estimate(t, measurement, command), self._estimator_check)

    def run_law(self, t: float, given: dict) -> dict:
        """The law's demand at t from `given` (the estimate, with the internal momentum if it reads it)."""
        return self._checked("law", t, self._controlling, lambda: self.law.torque(t, given), self._law_check)

    def run_allocator(self, t: float, demand: dict, estimate: dict, actuators: dict) -> dict:
        """The allocator's command at t, checked as in `tick`."""
        return self._checked("allocator", t, self._allocating,
                             lambda: self.allocator.allocate(t, demand, estimate, actuators), self._allocator_check)

    def _checked(self, slot: str, t: float, runs: bool, call, check) -> dict:
        """call()'s output, checked by `check` (None: not checked), or {} when the slot does not run;
        a failure raised as `tick` raises it."""
        try:
            if not runs:
                return {}
            out = call()
            if check is not None:
                check(t, out)
            return out
        except BaseException as exc:
            self._raise_failure(t, slot, exc)

    def statistics(self) -> dict:
        """slot -> the statistics of each stage that keeps them (`Declared.statistics`), as they are now."""
        return {slot: stats for slot, stage_object in self.stages().items()
                if (stats := Declared.of(stage_object).statistics) is not None}

    def sensed_signals(self) -> dict[str, dict[str, np.ndarray]]:
        """The sensor's and estimator's last outputs, as the trace records them between control instants."""
        return {"sensor": self.measurement, "estimator": self.estimate}

    def signals(self) -> dict[str, dict[str, np.ndarray]]:
        """The last tick's outputs by slot, as the trace records them."""
        return {"sensor": self.measurement, "estimator": self.estimate, "law": self.demand,
                "allocator": self.command}

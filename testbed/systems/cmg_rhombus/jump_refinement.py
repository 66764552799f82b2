"""The physics steps of a control tick whose gimbal commands jumped, taken finer.

A held gimbal-rate command that jumps (min-max steering chatters between the ends of a flat
optimum, a slew starts or stops) makes the held motor torque and the gimbal acceleration jump,
and RK4's error over the tick after it is what bounds the step: the flagship at dt 0.01 s
drifted 1.0e-8, at 0.005 s 5.6e-10. Taking that tick's steps REFINED times finer, where a
command jumped by more than JUMP_FRACTION of the rate limit, gives 9.4e-11 at dt 0.01 s for
3 % of the ticks (docs/theory/gimbal-servo.md, "Ticks after a command jump").
"""

from __future__ import annotations

import math

JUMP_FRACTION = 0.1  # of the gimbal-rate limit: a jump smaller than this is stepped as it is
JUMP_NO_LIMIT_RAD_S = math.radians(1.0)  # the same for a cluster with no rate limit (10 % of 10 deg/s)
REFINED = 4  # steps of dt / REFINED over a tick after a jump


class JumpRefinement:
    """Tells, once a tick, whether the gimbal commands held in `commands` (a view of MuJoCo's
    ctrl) jumped since the last tick by more than `threshold` [rad/s], and steps that tick's
    physics at timestep / `factor` (`stepper`)."""

    def __init__(self, model, commands, threshold: float, factor: int = REFINED):
        self.model, self.commands, self.threshold, self.factor = model, commands, threshold, factor
        self.last = commands.tolist()
        self.refined_ticks = 0

    def jumped(self) -> bool:
        """Whether the commands jumped since the last call (which is then this one)."""
        now = self.commands.tolist()
        jump = max(abs(a - b) for a, b in zip(now, self.last))
        self.last = now
        return jump > self.threshold

    def stepper(self, coarse, fine):
        """A tick's steps: `coarse()` at the model's timestep, or, after a jump, `fine()`
        (`factor` times the steps) at timestep / `factor`."""
        opt = self.model.opt

        def advance() -> None:
            if not self.jumped():
                coarse()
                return
            dt = opt.timestep
            opt.timestep = dt / self.factor
            try:
                fine()
            finally:
                opt.timestep = dt
            self.refined_ticks += 1
        return advance

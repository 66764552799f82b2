"""The physics steps of a control tick whose gimbal commands jumped, taken finer.

A held gimbal-rate command that jumps (min-max steering chatters between the ends of a flat
optimum, a slew starts or stops) makes the held motor torque and the gimbal acceleration jump,
and RK4's error over the tick after it is what bounds the step: the flagship at dt 0.01 s
drifted 1.0e-8, at 0.005 s 5.6e-10. Taking that tick's steps REFINED times finer, where a
command jumped by more than JUMP_FRACTION of the rate limit, gives 9.4e-11 at dt 0.01 s for
3 % of the ticks (docs/theory/gimbal-servo.md, "Ticks after a command jump"). An estimator
faster than the control steps a tick in several calls: the window is the whole tick.
"""

from __future__ import annotations

import functools
import math

JUMP_FRACTION = 0.1  # of the gimbal-rate limit: a jump smaller than this is stepped as it is
JUMP_NO_LIMIT_RAD_S = math.radians(1.0)  # the same for a cluster with no rate limit (10 % of 10 deg/s)
REFINED = 4  # steps of dt / REFINED over a tick after a jump


class JumpRefinement:
    """Tells whether the gimbal commands held in `commands` (a view of MuJoCo's ctrl) jumped by
    more than `threshold` [rad/s] since it last looked, and steps the physics of the next
    `window` seconds (the control period: the tick after the jump, however many calls it is
    stepped in) at timestep / `factor` (`stepper`)."""

    def __init__(self, model, data, commands, threshold: float, window: float, factor: int = REFINED):
        self.model, self.data, self.commands = model, data, commands
        self.threshold, self.window, self.factor = threshold, window, factor
        self.last = commands.tolist()
        self.until = -math.inf  # the end of the window after the last jump
        self.refined_calls = 0

    def refine_now(self) -> bool:
        """Whether the steps from now on are in the window after a jump (a jump since the last
        call opens one)."""
        now = self.commands.tolist()
        if max(abs(a - b) for a, b in zip(now, self.last)) > self.threshold:
            self.until = self.data.time + self.window
        self.last = now
        return self.data.time < self.until - 1e-9 * self.window  # a tick's end is the next one's start

    def advance(self, coarse, fine) -> None:
        """`coarse()` at the model's timestep, or, in the window after a jump, `fine()` (`factor`
        times the steps) at timestep / `factor`."""
        if not self.refine_now():
            coarse()
            return
        self.advance_fine(fine)

    def advance_fine(self, fine) -> None:
        """`fine()` (`factor` times the steps) at timestep / `factor`: a call in the window after a jump."""
        opt = self.model.opt
        dt = opt.timestep
        opt.timestep = dt / self.factor
        try:
            fine()
        finally:
            opt.timestep = dt
        self.refined_calls += 1

    def stepper(self, coarse, fine):
        """`advance` with these steps, as one call."""
        return functools.partial(self.advance, coarse, fine)

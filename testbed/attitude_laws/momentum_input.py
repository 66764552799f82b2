"""The law input `internal_momentum`: what a law reads to compensate ω × (I ω + H) itself.

A law (built-in or plug-in) that lists "internal_momentum" in its class attribute `inputs`
receives, in the dict it is called with, next to the estimator's keys, `internal_momentum`:
the momentum of the moving parts relative to the bus [N m s, body axes] as the actuators'
encoders and tachometers give it at that tick (`Plant.internal_momentum_body`; zeros for a
rigid body). Such a law publishes `compensates_internal_momentum` in its design data, and an
allocator that adds ω × H to the demand itself (a steering law: design key `internal_momentum`)
must say that it leaves it to the law (design key `law_compensation`), else the pair is
refused before the run (the term would be counted twice).
"""

from __future__ import annotations

from testbed.errors import InputError

INPUT = "internal_momentum"
DESIGN = {"compensates_internal_momentum": True}


def check_allocator(ctx, law: str) -> None:
    """Refuse an allocator that compensates ω × H itself next to a law that does."""
    allocator = ctx.stages.get("allocator")
    if allocator is None:
        return
    if "internal_momentum" in allocator.design and not allocator.design.get("law_compensation"):
        raise InputError("pipeline.allocator.type", f"{allocator.type} adds w x H to the demand itself, and law "
                         f"{law} compensates it too (internal_momentum): choose an allocator that leaves it to the law")

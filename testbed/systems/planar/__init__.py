"""Planar attitude rig of Avdeev & Kaptsova 2016 (SEEDS §001): one hinge about the inertial z
axis, regulated by the analytic optimal (AKOR) LQR law (models/planar.xml).

- model.py           `PlanarParams` (the `model:` block), `build`, the hinge and actuators by name
- plant.py           the hinge as the runner sees it (not a free body: no momentum metrics)
- akor_regulator.py  the paper's closed forms: Riccati, eta, settling time, ER0/ER1, power
- figures.py         the same figures measured from a recorded response
- stages.py          sensor `hinge_encoder`, estimator `hinge_state`, law `akor_lqr`
- metrics.py         each measured figure against its closed form
"""

from testbed.systems.planar import metrics, stages  # noqa: F401  (register)
from testbed.systems.planar.model import PlanarParams, build
from testbed.systems.planar.plant import PlanarPlant
from testbed.systems.registry import system


@system("planar", PlanarParams, free_flying=False)
def make_plant(params: PlanarParams, sim) -> PlanarPlant:
    return PlanarPlant(params, sim)


__all__ = ["PlanarParams", "PlanarPlant", "build", "make_plant"]

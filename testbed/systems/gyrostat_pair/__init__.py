"""Leader and follower gyrostats of seed 003: an invariant-manifold observer of the leader's
unmeasured rate, and the synchronisation of the follower with the leader
(models/gyrostat_pair.xml).

- model.py     `GyrostatPairParams` (the `model:` block with both initial states) and `build`
- plant.py     both gyrostats by name; the follower's rotor motors as the actuator
- observer.py  the observer (3), (8)-(13) and the synchronisation law (15)
- stages.py    sensor `leader_rates`, estimators `invariant_manifold` and `pass_through`,
               law `synchronisation`, allocator `follower_rotors`
- metrics.py   the observer's and the synchronisation's decay

Reference `gyrostat_leader`: the leader by eq. (1) with constant lambda (solve_ivp).
"""

from testbed.references.registry import reference
from testbed.systems.gyrostat_pair import metrics, stages  # noqa: F401  (register)
from testbed.systems.gyrostat_pair.model import GyrostatPairParams, build
from testbed.systems.gyrostat_pair.plant import GyrostatPairPlant
from testbed.systems.registry import system


@system("gyrostat_pair", GyrostatPairParams)
def make_plant(params: GyrostatPairParams, sim) -> GyrostatPairPlant:
    return GyrostatPairPlant(build(params, sim.dt_s, sim.integrator), params)


@reference("gyrostat_leader", systems=("gyrostat_pair",))
def _gyrostat_leader(plant, params):
    """The leader of the gyrostat-synchronisation paper (docs/theory/papers.md), eq. (1) with
    constant lambda: A w' + w x (A w + lambda) = 0 (solve_ivp); A = its locked inertia from mj_fullM, lambda = J x rotor speeds at t = 0."""
    from testbed.references.gyrostat_ode import gyrostat_omega

    inertia, moment, omega0 = plant.locked_inertia(), plant.moment("leader"), plant.omega()
    return lambda times, recorder: gyrostat_omega(inertia, moment, omega0, times - times[0])


__all__ = ["GyrostatPairParams", "GyrostatPairPlant", "build", "make_plant"]

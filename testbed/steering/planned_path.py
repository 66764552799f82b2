"""A gimbal path planned before the slew for a momentum program along one line, H_w(t) = s(t) d
(docs/theory/steering.md "Planned paths").

A law that sees only the present gimbal angles must fail somewhere in the outer band of the envelope
(elliptic singular states, singularity_type.py); one that knows H_w(t) ahead can choose, before the
slew, where on each fibre F(s) = {beta : H(beta) = s d} the gimbals should be. The plan is a global
search over the surface the fibres sweep for 0 <= s <= s_max (momentum_fibres.py):

- levels s_k = k s_max / L, k = 0..L (L = `levels`, fewer for a program so fast that the links between
  levels would reach less than LINKS_PER_SPACING samples: `level_count`); level 0 is the start's own
  fibre arc, as far as null motion at rest reaches in the rest before the slew (`reconfiguration_travel`
  [rad], the sum of each step's largest angle change); every other level is carried up from the one
  below (momentum_fibres.next_level);
- a graph: sample i of level k links to every sample j of level k + 1 with
  max_g |beta_j - beta_i| <= margin beta'max dt_k (and at most `link_radius`), dt_k the least time the
  program spends between s_k and s_(k+1) (its largest |s'| there), so the linear path between them
  keeps every gimbal rate below margin beta'max; a sample weighs m = sqrt(det(J J^T));
- the widest path (Pollack 1960, the maximum-capacity route; here a sweep level by level, the graph
  being layered): the largest bottleneck m* = max over paths of the smallest m on them, from the start
  along its arc to the top level; among the paths whose samples keep m >= min(m*, m_target), the one of
  least gimbal travel (Euclidean, the arc at rest included) by a second sweep;
- beta(t) = the path at s(t) (linear between levels, Newton back onto H = s(t) d), the same path down
  as up, so any program with 0 <= s(t) <= s_max is flown. Refused (a `Refusal` that says why) when
  m* < measure_floor, when no sample reaches s_max, or when the timed path's smallest m or peak rate
  misses the floor or beta'max; a refused plan is tried again on finer samples (plan_gimbal_path).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.steering.momentum_fibres import TAU, difference, measures, next_level, onto_level, trace_chain, wrapped

M_TARGET, MEASURE_FLOOR = 0.3, 0.05
LINK_RADIUS = 0.3  # [rad] the most any gimbal moves between two levels of the plan
# The planner's work bound (docs/theory/steering.md "What a plan costs"): a fibre of the unit
# pyramid is at most FIBRE_LENGTH [rad] long (longest traced: 75 rad, skews 30-80 deg), its samples
# at least CROWDING x spacing apart, so a level holds at most FIBRE_LENGTH / (CROWDING spacing)
# samples, each linked to at most 2 LINK_RADIUS / (CROWDING spacing) + 1 of the next level.
FIBRE_LENGTH, CROWDING = 100.0, 0.6
PLAN_WORK_LIMIT = 1e8  # at worst about 50 s of CPU (15 us a sample, measured); 4.1e6 by default
# The least reach of a link between two levels, in sample spacings: shorter, a sample links only to the one
# carried up from it and null motion between levels is lost (a 20 s slew refused at 0.53 of the pyramid's
# support with 60 levels, flown with 32; docs/theory/steering.md "Planned paths").
LINKS_PER_SPACING = 1.4
# The divisors of the sample spacing a refused plan is tried again with (plan_gimbal_path).
REFINEMENTS = (1, 2, 3)


@dataclass(slots=True)
class PlannedPath:
    """times (K+1,) [s], angles (K+1, n) [rad] of the plan; reconfiguration (m, n): the start's fibre arc
    from the start to angles[0], flown at rest before the slew; its smallest sqrt(det J J^T), peak
    rate [rad/s] and the bottleneck m* of the search."""

    times: np.ndarray
    angles: np.ndarray
    reconfiguration: np.ndarray
    min_measure: float
    peak_rate: float
    bottleneck: float

    def at(self, t: float) -> np.ndarray:
        """The planned angles at time t (linear between the plan's steps, held past its ends)."""
        return np.array([np.interp(t, self.times, column) for column in self.angles.T])

    def reconfigured_at(self, fraction: float) -> np.ndarray:
        """The angles `fraction` (0..1) of the way along the reconfiguration, by travel (largest angle change)."""
        steps = np.abs(np.diff(self.reconfiguration, axis=0)).max(axis=-1) if len(self.reconfiguration) > 1 else []
        travel = np.concatenate([[0.0], np.cumsum(steps)])
        if travel[-1] == 0.0:
            return self.reconfiguration[-1].copy()
        where = float(np.clip(fraction, 0.0, 1.0)) * travel[-1]
        return np.array([np.interp(where, travel, column) for column in self.reconfiguration.T])

    @property
    def travel_at_rest(self) -> float:
        """The reconfiguration's travel [rad]: the sum of each step's largest angle change."""
        return float(np.abs(np.diff(self.reconfiguration, axis=0)).max(axis=-1).sum()) if len(self.reconfiguration) > 1 else 0.0


@dataclass(slots=True)
class Refusal:
    """Why no plan was found: the paths reachable from the start (within the rate margin, above the floor)
    end at `reached` (0..1) of the program's peak momentum, where the best of them keeps sqrt(det(J J^T)) =
    `measure` (nan where the fibres themselves end); reached = 1 with `peak_rate` [rad/s] set: the timed
    path breaks the rate limit `rate_max` or the floor (its smallest measure); reached = 1 alone: every path
    to the peak passes below the floor."""

    reached: float
    measure: float
    rate_margin: float
    measure_floor: float
    rate_max: float
    peak_rate: float | None = None

    def reason(self) -> str:
        """One line for the user."""
        m = self.measure
        if self.reached < 1.0 and not np.isfinite(m):
            return (f"no gimbal state with sqrt(det(J J^T)) >= {self.measure_floor:g} holds {self.reached:.2f} of "
                    "the slew's peak momentum along its axis")
        if self.reached < 1.0:
            return (f"the gimbal paths found from the start within {self.rate_margin:g} of the rate limit reach only "
                    f"{self.reached:.2f} of the slew's peak momentum (sqrt(det(J J^T)) {m:.2f} where they end): the slew "
                    "asks for more torque there than the cluster gives")
        if self.peak_rate is not None:
            return (f"the timed path reaches {np.degrees(self.peak_rate):.3g} deg/s against the limit "
                    f"{np.degrees(self.rate_max):.3g} deg/s, sqrt(det(J J^T)) {m:.3g} at its lowest")
        return f"every path to the peak passes sqrt(det(J J^T)) below {self.measure_floor:g} (the best keeps {m:.3f})"


def planning_work(levels: int, spacing: float) -> float:
    """The bound on the planner's work (module doc): (levels + 1) x samples per level x (1 + links per
    sample), for `levels` momentum levels and samples `spacing` [rad] apart."""
    samples = FIBRE_LENGTH / (CROWDING * spacing)
    links = 2 * LINK_RADIUS / (CROWDING * spacing) + 1
    return (levels + 1) * samples * (1 + links)


def level_count(times: np.ndarray, levels_of_time: np.ndarray, rate_max: float, levels: int, spacing: float,
                rate_margin: float) -> int:
    """The levels L to plan on: at most `levels`, and few enough that a link at the program's fastest
    climb, margin beta'max dt with dt = (s_max / L) / max |s'|, reaches LINKS_PER_SPACING x `spacing` [rad];
    at least 4. A fast program thus gets fewer, taller levels (never more work than `levels` would take)."""
    fastest = float((np.abs(np.diff(levels_of_time)) / np.diff(times)).max()) if len(times) > 1 else 0.0
    if not fastest > 0:
        return levels
    reach = rate_margin * rate_max * float(levels_of_time.max()) / (fastest * LINKS_PER_SPACING * spacing)
    return int(min(levels, max(4, np.floor(reach))))


def least_times(times: np.ndarray, levels_of_time: np.ndarray, level_values: np.ndarray) -> np.ndarray:
    """dt_k = (s_(k+1) - s_k) / max |s'| over the program's steps that cross [s_k, s_(k+1)]: the least time
    between the levels, on the way up or down (inf for an interval the program never crosses)."""
    ds = level_values[1] - level_values[0]
    slope = np.abs(np.diff(levels_of_time)) / np.diff(times)
    low = np.minimum(levels_of_time[:-1], levels_of_time[1:])
    high = np.maximum(levels_of_time[:-1], levels_of_time[1:])
    first = np.clip(np.floor(low / ds).astype(int), 0, len(level_values) - 2)
    last = np.clip(np.ceil(high / ds).astype(int) - 1, 0, len(level_values) - 2)
    fastest = np.zeros(len(level_values) - 1)
    for a, b, v in zip(first, last, slope):
        fastest[a:b + 1] = np.maximum(fastest[a:b + 1], v)
    return np.where(fastest > 0, ds / np.maximum(fastest, 1e-300), np.inf)


def _links(lower: np.ndarray, upper: np.ndarray, radius: float):
    """(i, j, Euclidean travel) for every pair of samples with max_g |upper_j - lower_i| <= radius (on the torus)."""
    from scipy.spatial import cKDTree  # on use: at the top it would cost every command start-up time
    pairs = cKDTree(lower, boxsize=TAU).sparse_distance_matrix(cKDTree(upper, boxsize=TAU), radius, p=np.inf,
                                                                  output_type="ndarray")
    i, j = pairs["i"].astype(int), pairs["j"].astype(int)
    return i, j, np.linalg.norm(difference(upper[j], lower[i]), axis=-1)


def plan_gimbal_path(momentum, jacobian, start, direction, times, levels_of_time, rate_max: float, *,
                     reconfiguration_travel: float, levels: int = 60, spacing: float = np.radians(3.0),
                     link_radius: float = LINK_RADIUS, rate_margin: float = 0.9, m_target: float = M_TARGET,
                     measure_floor: float = MEASURE_FLOOR, refinements=REFINEMENTS) -> PlannedPath | Refusal:
    """The plan of the module doc for the cluster's unit-h `momentum(B)` and `jacobian(B)` (stacked angles),
    the start angles (on H = s(0) d), the unit `direction` d and the program's s(t) [h] at `times` [s];
    a Refusal (why) when refused. Angles in the plan run on continuously from the start (not wrapped).

    A plan refused at `spacing` is planned again on samples `spacing` / 2, then / 3 apart (`refinements`),
    as long as the work bounds of the passes so far add up to at most PLAN_WORK_LIMIT: a link must fit
    the climb between two levels and the offset of the samples along the fibre (up to a spacing), so a
    program that needs most of the rate limit to climb loses its links to the sampling alone."""
    spent, plan = 0.0, None
    for divisor in refinements:
        spent += planning_work(levels, spacing / divisor)
        if plan is not None and spent > PLAN_WORK_LIMIT:
            break
        plan = _plan_on_samples(momentum, jacobian, start, direction, times, levels_of_time, rate_max,
                                reconfiguration_travel, levels, spacing / divisor, link_radius, rate_margin, m_target,
                                measure_floor)
        if isinstance(plan, PlannedPath):
            break
    return plan


def _plan_on_samples(momentum, jacobian, start, direction, times, levels_of_time, rate_max, reconfiguration_travel,
                     levels, spacing, link_radius, rate_margin, m_target, measure_floor) -> PlannedPath | Refusal:
    """One pass of the plan (plan_gimbal_path's arguments) on fibre samples `spacing` [rad] apart."""
    start, direction = np.asarray(start, float), np.asarray(direction, float)
    times, levels_of_time = np.asarray(times, float), np.asarray(levels_of_time, float)
    s_max = float(levels_of_time.max())
    levels = level_count(times, levels_of_time, rate_max, levels, spacing, rate_margin)
    values = np.linspace(0.0, s_max, levels + 1)
    dt = least_times(times, levels_of_time, values)

    arc, at_start = trace_chain(momentum, jacobian, start, levels_of_time[0] * direction, spacing, measure_floor,
                                reconfiguration_travel)
    arc_measure = measures(jacobian, arc)
    bottleneck = np.full(len(arc), -np.inf)  # the smallest m on the way from the start along the arc
    for way in (range(at_start, len(arc)), range(at_start, -1, -1)):
        bottleneck[list(way)] = np.minimum.accumulate(arc_measure[list(way)])
    travel = np.zeros(len(arc))
    for way in (range(at_start, len(arc)), range(at_start, -1, -1)):
        way = list(way)
        steps = np.linalg.norm(difference(arc[way[1:]], arc[way[:-1]]), axis=-1)
        travel[way] = np.concatenate([[0.0], np.cumsum(steps)])

    def refused(reached: float, measure: float, peak: float | None = None) -> Refusal:
        return Refusal(reached, measure, rate_margin, measure_floor, rate_max, peak)

    nodes, weights, links = [arc], [arc_measure], []
    chains = [arc]
    for k in range(levels):
        chains = next_level(momentum, jacobian, chains, direction, values[k], values[k + 1], spacing, measure_floor)
        if not chains:
            return refused(values[k] / s_max, np.nan)
        upper = np.concatenate(chains)
        radius = min(rate_margin * rate_max * dt[k], link_radius)
        links.append(_links(nodes[-1], upper, radius))
        nodes.append(upper)
        weights.append(measures(jacobian, upper))

    # first sweep: the widest bottleneck reaching each sample
    widest = [bottleneck]
    for k, (i, j, _) in enumerate(links):
        reached = np.full(len(nodes[k + 1]), -np.inf)
        np.maximum.at(reached, j, np.minimum(widest[k][i], weights[k + 1][j]))
        widest.append(reached)
    best = float(widest[-1].max())
    if not np.isfinite(best):  # the last level any path reaches, and the best measure there
        last = max(k for k, reached in enumerate(widest) if np.isfinite(reached).any())
        return refused(values[last] / s_max, float(widest[last].max()))
    if not best >= measure_floor:
        return refused(1.0, best)

    # second sweep: least travel through samples with m >= the threshold
    threshold = min(best, m_target) * (1 - 1e-12)
    cost = [np.where(bottleneck >= threshold, travel, np.inf)]
    previous = []
    for k, (i, j, w) in enumerate(links):
        candidate = cost[k][i] + w
        usable = np.isfinite(candidate) & (weights[k + 1][j] >= threshold)
        ci, cj, cv = i[usable], j[usable], candidate[usable]
        order = np.lexsort((cv, cj))
        first = order[np.concatenate([[True], cj[order][1:] != cj[order][:-1]])] if len(order) else order
        reached, came_from = np.full(len(nodes[k + 1]), np.inf), np.full(len(nodes[k + 1]), -1)
        reached[cj[first]], came_from[cj[first]] = cv[first], ci[first]
        cost.append(reached)
        previous.append(came_from)
    if not np.isfinite(cost[-1]).any():
        return refused(1.0, best)
    chosen = [int(np.argmin(cost[-1]))]
    for came_from in reversed(previous):
        chosen.append(int(came_from[chosen[-1]]))
    chosen.reverse()

    # the arc at rest from the start to the path's first sample, then the path, unwrapped
    j0 = chosen[0]
    way = list(range(at_start, j0 + 1)) if j0 >= at_start else list(range(at_start, j0 - 1, -1))
    rest = start + np.concatenate([[np.zeros(4)], np.cumsum(difference(arc[way[1:]], arc[way[:-1]]), axis=0)])
    path = [rest[-1]]
    for k in range(1, levels + 1):
        path.append(path[-1] + difference(nodes[k][chosen[k]], nodes[k - 1][chosen[k - 1]]))
    path = np.array(path)

    # time it: the path at s(t), Newton back onto the level
    position = np.clip(levels_of_time / (values[1] - values[0]) if s_max > 0 else 0 * times, 0, levels)
    low = np.minimum(np.floor(position).astype(int), levels - 1)
    angles = path[low] + (position - low)[:, None] * (path[low + 1] - path[low])
    moved, landed = onto_level(momentum, jacobian, angles, levels_of_time[:, None] * direction)
    angles = np.where(landed[:, None], angles + difference(moved, angles), angles)
    peak = float((np.abs(np.diff(angles, axis=0)).max(axis=-1) / np.diff(times)).max())
    lowest = float(min(measures(jacobian, angles).min(), arc_measure[way].min()))
    if lowest < measure_floor or peak > rate_max or not landed.all():
        return refused(1.0, lowest, peak)
    return PlannedPath(times, angles, rest, lowest, peak, best)

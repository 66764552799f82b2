"""The fibres F(s) = {beta : H(beta) = s d} of a momentum line, sampled level by level
(docs/theory/steering.md "Planned paths").

For n = 4 gimbals and 3 momentum components a fibre is a set of closed curves in the 4-torus, smooth
where J = dH/dbeta has rank 3; its tangent is the null vector n_i = (-1)^i det(J without column i)
(|n| = sqrt(det(J J^T)) by Cauchy-Binet). A level is a list of chains, each an ordered run of
samples about `spacing` [rad] apart on one fibre arc with sqrt det >= the floor:

- `trace_chain` follows one fibre from a point both ways by continuation (a step of `spacing` along
  n / |n|, Newton back onto the level), until sqrt det falls below the floor, the arc meets a sample
  already taken, or its travel (the sum of each step's largest angle change) reaches a bound;
- `next_level` carries a level to the next s: the pseudo-inverse step (s' - s) J^+ d, then Newton
  (`onto_level`); it refills the gaps a stretching fibre opens, thins what a shrinking one crowds,
  cuts a chain where a sample is lost, and grows each chain's ends a few steps by continuation.

Every function is numpy-vectorised over the samples; angles are kept in [0, 2 pi) and differences
wrapped to [-pi, pi). `momentum(B)` (unit h, (..., 3)) and `jacobian(B)` ((..., 3, 4)) are the
cluster's own functions, taking stacked angles B (m, 4).
"""

from __future__ import annotations

import numpy as np

from testbed.steering.minimax_exact import cofactor_null_vector

TAU = 2 * np.pi
CONVERGED = 1e-9  # |H(beta) - s d| [h] below which Newton has landed on the level


def wrapped(angles: np.ndarray) -> np.ndarray:
    """Angles in [0, 2 pi) (a cKDTree with boxsize 2 pi needs them strictly below it)."""
    out = np.mod(angles, TAU)
    return np.where(out >= TAU, 0.0, out)


def difference(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a - b on the torus, each angle in [-pi, pi)."""
    return np.mod(np.asarray(a) - np.asarray(b) + np.pi, TAU) - np.pi


def null_vectors(J: np.ndarray) -> np.ndarray:
    """n_i = (-1)^i det(J without column i) for stacked 3x4 J (..., 3, 4): J n = 0, |n| = sqrt(det(J J^T))
    (minimax_exact.cofactor_null_vector, applied elementwise to the stack)."""
    return np.stack(cofactor_null_vector(np.moveaxis(np.asarray(J, float), (-2, -1), (0, 1))), axis=-1)


def measures(jacobian, B: np.ndarray) -> np.ndarray:
    """sqrt(det(J J^T)) at each row of B (m, 4), as the length of the null vector (Cauchy-Binet)."""
    return np.linalg.norm(null_vectors(jacobian(B)), axis=-1)


def onto_level(momentum, jacobian, B: np.ndarray, target: np.ndarray, iterations: int = 4):
    """Newton with the minimum-norm step beta <- beta - J^T (J J^T)^{-1} (H(beta) - target) from each row of
    B (m, 4) onto H = target (3,): (angles in [0, 2 pi), landed mask: |H - target| < CONVERGED and J of full rank)."""
    B = np.array(B, float)
    for _ in range(iterations):
        J = jacobian(B)
        gram = J @ np.swapaxes(J, -1, -2)
        ok = np.linalg.det(gram) > 1e-12
        gram[~ok] = np.eye(3)
        residual = momentum(B) - target
        B = B - np.where(ok[:, None], (np.swapaxes(J, -1, -2) @ np.linalg.solve(gram, residual[..., None]))[..., 0], 0)
    landed = np.linalg.norm(momentum(B) - target, axis=-1) < CONVERGED
    return wrapped(B), landed & ok


def _step_along(momentum, jacobian, points, heading, target, spacing):
    """One continuation step from each row of points along +-n/|n| (the sign keeping n . heading > 0), then Newton:
    (new points, their unit tangents, landed mask)."""
    n = null_vectors(jacobian(points))
    size = np.linalg.norm(n, axis=-1, keepdims=True)
    tangent = np.sign(np.sum(n * heading, axis=-1, keepdims=True) + 1e-300) * n / np.maximum(size, 1e-300)
    moved, landed = onto_level(momentum, jacobian, points + spacing * tangent, target)
    return moved, tangent, landed & (size[:, 0] > 0)


def extend_ends(momentum, jacobian, chains: list[np.ndarray], target, spacing: float, floor: float,
                steps: int, travel_bound: float = np.inf, seeds_heading=None) -> list[np.ndarray]:
    """Each chain of the level grown at both ends by up to `steps` continuation steps (module doc): an end stops
    where sqrt det < floor, Newton fails, it comes within 0.6 spacing of a sample of the level, or its travel
    reaches `travel_bound`. A one-sample chain grows both ways (along +n and -n, or +-seeds_heading)."""
    if not chains or steps <= 0:
        return chains
    from scipy.spatial import cKDTree  # on use: at the top it would cost every command start-up time
    others = cKDTree(wrapped(np.concatenate(chains)), boxsize=TAU)
    points, headings, owner, front = [], [], [], []
    for c, chain in enumerate(chains):
        if len(chain) == 1:
            heading = null_vectors(jacobian(chain[:1]))[0] if seeds_heading is None else seeds_heading
            ends = [(chain[0], heading, True), (chain[0], -heading, False)]
        else:
            ends = [(chain[0], difference(chain[0], chain[1]), True), (chain[-1], difference(chain[-1], chain[-2]), False)]
        for point, heading, at_front in ends:
            points.append(point), headings.append(heading), owner.append(c), front.append(at_front)
    points, headings = np.array(points), np.array(headings)
    grown = [[] for _ in points]
    active, travel = np.ones(len(points), bool), np.zeros(len(points))
    for _ in range(steps):
        index = np.flatnonzero(active)
        if not len(index):
            break
        moved, tangent, landed = _step_along(momentum, jacobian, points[index], headings[index], target, spacing)
        step = np.abs(difference(moved, points[index])).max(axis=-1)
        crowded = others.query(moved, k=1)[0] < 0.6 * spacing
        keep = landed & ~crowded & (measures(jacobian, moved) >= floor) & (travel[index] + step <= travel_bound)
        for k, i in enumerate(index):
            if keep[k]:
                grown[i].append(moved[k])
        travel[index] += step
        points[index[keep]], headings[index[keep]] = moved[keep], tangent[keep]
        active[index[~keep]] = False
    out = [chain for chain in chains]
    for i, c in enumerate(owner):
        if grown[i]:
            new = np.array(grown[i])
            out[c] = np.concatenate([new[::-1], out[c]]) if front[i] else np.concatenate([out[c], new])
    return out


def trace_chain(momentum, jacobian, start, target, spacing: float, floor: float, travel_bound: float,
                steps: int = 2000) -> tuple[np.ndarray, int]:
    """The fibre arc through `start` (on H = target) both ways (module doc), ordered: (samples (m, 4), the index
    of start in them). Each way stops at sqrt det < floor or at `travel_bound` [rad] of travel."""
    start = wrapped(np.asarray(start, float))[None]
    heading = null_vectors(jacobian(start))[0]
    front = extend_ends(momentum, jacobian, [start], target, spacing, floor, steps, travel_bound, heading)[0]
    index = int(np.flatnonzero(np.all(front == start[0], axis=-1))[0])
    return front, index


def _split(chain: np.ndarray, keep: np.ndarray, cut_after: np.ndarray) -> list[np.ndarray]:
    """The runs of chain rows with `keep`, also cut between rows i and i + 1 where cut_after[i]."""
    breaks = ~keep | np.concatenate([[False], cut_after])  # a run starts anew at a dropped row or after a cut
    runs, label = [], np.cumsum(breaks)
    for value in np.unique(label[keep]):
        runs.append(chain[keep & (label == value)])
    return runs


def _thinned(chain: np.ndarray, least: float) -> np.ndarray:
    """The chain keeping a sample only once it is `least` [rad] (Euclidean) past the last one kept."""
    kept, last = np.ones(len(chain), bool), 0
    for i in range(1, len(chain)):
        if np.linalg.norm(difference(chain[i], chain[last])) < least:
            kept[i] = False
        else:
            last = i
    return chain[kept]


def _refilled(momentum, jacobian, chain, target, spacing, floor) -> list[np.ndarray]:
    """The chain with points put (linearly, then Newton onto the level) where two samples are more than 1.5 spacing
    apart, thinned to at least 0.7 spacing apart, cut where a filled point is lost or a gap stays above 3 spacing."""
    if len(chain) < 2:
        return [chain]
    gaps = np.linalg.norm(difference(chain[1:], chain[:-1]), axis=-1)
    extra = np.where(gaps > 1.5 * spacing, np.ceil(gaps / spacing).astype(int) - 1, 0)
    extra = np.minimum(extra, 8)
    if extra.any():
        rows, lost = [chain[:1]], [False]
        for i in range(len(chain) - 1):
            if extra[i]:
                fractions = np.arange(1, extra[i] + 1)[:, None] / (extra[i] + 1)
                rows.append(chain[i] + fractions * difference(chain[i + 1], chain[i]))
                lost += [True] * extra[i]  # marks the filled rows, checked below
            rows.append(chain[i + 1:i + 2])
            lost.append(False)
        chain, filled = np.concatenate(rows), np.array(lost)
        moved, landed = onto_level(momentum, jacobian, chain[filled], target)
        chain[filled] = moved
        keep = np.ones(len(chain), bool)
        keep[filled] = landed & (measures(jacobian, moved) >= floor)
    else:
        keep = np.ones(len(chain), bool)
    runs = []
    for run in _split(chain, keep, np.zeros(len(chain) - 1, bool)):
        run = _thinned(run, 0.7 * spacing)
        far = np.linalg.norm(difference(run[1:], run[:-1]), axis=-1) > 3 * spacing if len(run) > 1 else np.zeros(0, bool)
        runs += _split(run, np.ones(len(run), bool), far)
    return runs


def next_level(momentum, jacobian, chains: list[np.ndarray], direction, s_from: float, s_to: float, spacing: float,
               floor: float, grow_steps: int = 3) -> list[np.ndarray]:
    """The chains of the level s_to from those of the level s_from (module doc)."""
    direction = np.asarray(direction, float)
    target = s_to * direction
    if not chains:
        return []
    B = np.concatenate(chains)
    J = jacobian(B)
    gram = J @ np.swapaxes(J, -1, -2)
    ok = np.linalg.det(gram) > 1e-12
    gram[~ok] = np.eye(3)
    step = (np.swapaxes(J, -1, -2) @ np.linalg.solve(gram, np.broadcast_to((s_to - s_from) * direction, B.shape[:1] + (3,))[..., None]))[..., 0]
    landed_all, ok_all = onto_level(momentum, jacobian, B + step, target)
    alive = ok & ok_all & (measures(jacobian, landed_all) >= floor)
    out, offset = [], 0
    for chain in chains:
        rows = slice(offset, offset + len(chain))
        offset += len(chain)
        for run in _split(landed_all[rows], alive[rows], np.zeros(len(chain) - 1, bool)):
            out += _refilled(momentum, jacobian, run, target, spacing, floor)
    return extend_ends(momentum, jacobian, out, target, spacing, floor, grow_steps)

"""min-max steering with a price on null motion (testbed/steering/minimax_exact.py,
`null_motion_price`; docs/theory/steering.md "A price on null motion")."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from testbed.errors import InputError
from testbed.steering import minimax_steering
from testbed.steering.minimax_exact import priced_line_parameter


def brute_force(x, n, price):
    """The minimum of max_i |x_i + t n_i| + price |n| |t - t0| on a dense grid, then a finer
    one around the best point (independent of the kink enumeration)."""
    x, n = np.asarray(x), np.asarray(n)
    t0 = -(x @ n) / (n @ n)
    objective = lambda t: np.max(np.abs(x[None] + t[:, None] * n[None]), axis=1) + price * np.linalg.norm(n) * np.abs(t - t0)
    scale = (np.abs(x).max() + 1.0) / np.abs(n).max() * 4.0
    grid = np.linspace(t0 - scale, t0 + scale, 200001)
    for _ in range(3):
        best = grid[np.argmin(objective(grid))]
        step = grid[1] - grid[0]
        grid = np.linspace(best - 2 * step, best + 2 * step, 2001)
    return float(objective(np.array([best]))[0])


vector = st.lists(st.floats(-3, 3, allow_nan=False), min_size=4, max_size=4)


@settings(max_examples=200, deadline=None)
@given(x=vector, n=vector, price=st.floats(0.0, 1.0))
def test_the_priced_minimum_is_the_brute_force_minimum(x, n, price):
    """The objective is convex and piecewise linear: its value at the returned t equals the grid
    minimum to the grid's resolution (well conditioned: 1e-7 of the scale)."""
    if np.linalg.norm(n) < 1e-3:
        return
    t = priced_line_parameter(x, n, price)
    xv, nv = np.asarray(x), np.asarray(n)
    t0 = -(xv @ nv) / (nv @ nv)
    got = np.max(np.abs(xv + t * nv)) + price * np.linalg.norm(nv) * abs(t - t0)
    assert got <= brute_force(x, n, price) + 1e-7 * (np.abs(xv).max() + 1.0)


def test_a_nearly_flat_min_max_no_longer_jumps():
    """The flagship's chattering case (numbers from its run at t = 160.40 s and 160.50 s): gimbal 1
    saturates with a null component of +-0.003 while gimbals 2 and 4 carry the null motion. The
    paper's min-max puts the null coordinate at opposite ends (+16 and -16, gimbals 2 and 4 from
    -10 to +9.5 deg/s); priced, both ticks take the minimum-norm rates, for a peak rate at most
    6 % above the min-max one (measured 1.4 % and 5.8 %: the flat side's slope, |n_1| |t|)."""
    cases = [([-3.639, -0.174, -3.464, 0.0], [0.0031, 0.2206, 0.0029, -0.2207]),
             ([-3.687, 0.0, -3.525, -0.176], [-0.0141, 0.2202, -0.0132, -0.2199])]
    paper, priced = [], []
    for x, n in cases:
        J = null_space_jacobian(n)
        b = J @ np.array(x)
        paper.append(minimax_steering(J, 1.0, b, 1e3).beta_rate)
        priced.append(minimax_steering(J, 1.0, b, 1e3, null_motion_price=0.1).beta_rate)
    for exact, rates, (x, n) in zip(paper, priced, cases):
        n = np.asarray(n)
        assert abs(exact @ n) / np.linalg.norm(n) > 3.0  # the paper's far end of the flat side
        assert abs(rates @ n) < 1e-9 * np.linalg.norm(n)  # no null component: the minimum norm
        assert np.abs(exact).max() <= np.abs(rates).max() <= 1.06 * np.abs(exact).max()
    assert (paper[0] @ np.asarray(cases[0][1])) * (paper[1] @ np.asarray(cases[1][1])) < 0  # opposite ends


def null_space_jacobian(n):
    """A 3 x 4 Jacobian whose null space is n (rows: an orthonormal basis of n's complement)."""
    n = np.asarray(n, float) / np.linalg.norm(n)
    basis = np.linalg.svd(np.eye(4) - np.outer(n, n))[0][:, :3]
    return basis.T


def test_a_steep_min_max_is_kept():
    """Away from the degenerate case the price does not move the paper's optimum."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        J, b = rng.normal(size=(3, 4)), rng.normal(size=3)
        exact = minimax_steering(J, 1.0, b, 1e3).beta_rate
        slopes = np.abs(np.linalg.svd(J)[2][-1])
        if slopes.min() > 0.3:  # every gimbal's line is steep
            np.testing.assert_allclose(minimax_steering(J, 1.0, b, 1e3, null_motion_price=0.1).beta_rate, exact,
                                       rtol=1e-12, atol=1e-12)


def test_a_price_outside_its_range_is_refused():
    with pytest.raises(InputError, match="null_motion_price"):
        minimax_steering(np.eye(3, 4), 1.0, np.ones(3), 1.0, null_motion_price=-0.1)

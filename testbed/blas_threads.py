"""One BLAS thread while a scenario runs.

The testbed's linear algebra is on matrices of a few rows (3x3 inertias and rotations, 3x4
Jacobians, 12x12 observer pairs). OpenBLAS, which NumPy and SciPy each ship, still hands some
of them to its thread pool: SciPy's `expm` of the gimbal servo's 3x3 augmented matrix
(testbed/systems/cmg_rhombus/gimbal_servo.py) wakes it at every plant build, and its threads
then spin for about 55 ms of CPU on the other core (measured with `time.process_time` against
`time.thread_time`). That is 6 % of a core during a one-second run, taken from whatever else runs
(a campaign's second worker, the test suite), for no speed-up: single-threaded, the same call
takes 0.01 ms. threadpoolctl sets the pools of every BLAS library loaded in the process.
"""

from __future__ import annotations

import scipy.linalg  # noqa: F401  (loads SciPy's own OpenBLAS, so that the controller finds it)
from threadpoolctl import ThreadpoolController

_controller: ThreadpoolController | None = None


def one_blas_thread():
    """A context in which every BLAS library of this process runs on the calling thread only
    (the libraries are listed once, at the first call: about 3 ms)."""
    global _controller
    if _controller is None:
        _controller = ThreadpoolController()
    return _controller.limit(limits=1, user_api="blas")

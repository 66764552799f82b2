"""Pipeline stages; importing this package registers every stage by name."""

from testbed.stages import open_loop, rate_gyro, steering  # noqa: F401
from testbed.stages import attitude_sensor, slew  # noqa: F401  (issue 3: reorientation)
from testbed.stages import lebedev  # noqa: F401  (issue 4: one-gyro spin control)
from testbed.stages import planar  # noqa: F401  (issue 5: planar AKOR regulator)
from testbed.stages import gyrostat_pair, gyrostat_program  # noqa: F401  (issue 6: gyrostats)

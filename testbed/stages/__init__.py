"""Pipeline stages; importing this package registers every stage by name."""

from testbed.stages import open_loop, rate_gyro, steering  # noqa: F401

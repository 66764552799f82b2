"""Gyrodyne testbed: MuJoCo spacecraft attitude control with control-moment gyroscopes."""

__version__ = "0.1.0"

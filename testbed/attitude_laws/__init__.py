"""Attitude regulation laws that compensate the gyroscopic torque of the whole spacecraft,
ω × (I ω + H), reading the internal momentum H through the law input `internal_momentum`
(testbed.attitude_laws.momentum_input): quaternion feedback with a rate limit (Wie) and MRP
feedback (Schaub)."""

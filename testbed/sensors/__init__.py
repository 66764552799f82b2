"""Attitude sensors as models of their errors: a three-axis gyro package (Farrenkopf's model,
sampled exactly), a star tracker (noise across and about its boresight, latency, dropouts) and
the stage that reads both at their own rates (docs/theory/attitude_determination.md)."""

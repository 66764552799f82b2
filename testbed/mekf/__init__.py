"""The multiplicative extended Kalman filter of Lefferts, Markley & Shuster (1982): attitude and
gyro biases from a gyro package and a star tracker (docs/theory/attitude_determination.md)."""

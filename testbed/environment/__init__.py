"""The spacecraft's surroundings in orbit: the environment torques (gravity gradient, drag,
solar pressure, a residual dipole in the geomagnetic field) and the momentum-management loop
(magnetometer, magnetorquers, the cross-product desaturation law), applied to the bus through
MuJoCo's `xfrc_applied` (docs/theory/environment.md)."""

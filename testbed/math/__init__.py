"""Shared mathematics: quaternions, z-x-z Euler kinematics, fixed-step RK4, input checks."""

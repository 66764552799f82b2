"""Physical systems: one MJCF file in `models/` plus a module that applies parameters with
MjSpec and knows the compiled model's joints and actuators by name (dm_control style)."""

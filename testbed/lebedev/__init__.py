"""Lebedev's method on a gyrostat: the estimator and control stage, its observers (held,
continuous, momentum-aware, end-momentum), its metrics and its closed-loop reference; each
module registers what it defines when imported by testbed.plugins.discover."""

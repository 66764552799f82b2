"""Driving a run from Python: a period at a time (`simulation.Simulation`), and Python objects
in the pipeline's slots in place of registered stages (`given_stages`). docs/stepping.md.

The package imports nothing at its top: the run's plan (testbed.run_core.plan) imports
`given_stages`, and `simulation` imports the run core."""

"""Campaigns (`testbed sweep`): a sweep's spec and dispersions, the cases it expands to, the
values each case ran with, the engine that runs them, their rows, table, statistics and plots."""

"""The accuracy guard: whether a run's integration can be trusted (docs/theory/accuracy.md).

On by default for every run, relaxed per scenario with the `accuracy:` block
(`settings.AccuracySettings`): a step-size check before the first step (`step_size`), and after
the run the conservation, step-angle and tracking monitors (`guard`).
"""

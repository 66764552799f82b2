"""One package per physical system; each registers itself when imported (testbed.plugins.discover).

A system package owns everything about one MJCF file of models/: its one parameter
dataclass (the `model:` schema), `build()` through MjSpec, its plant, and its own stages,
metrics and references.
"""

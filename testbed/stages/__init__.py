"""Generic pipeline stages, usable on more than one system: one module per stage family, each
registering its stages (and the metrics of what they record) when imported by
testbed.plugins.discover. A system's own stages live in its package under testbed/systems/."""

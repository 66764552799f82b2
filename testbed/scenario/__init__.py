"""Scenarios: their types, loading and overrides (`loading`), reading the YAML, the parameter
schema of every section, and the files shipped with the package (models, scenarios)."""

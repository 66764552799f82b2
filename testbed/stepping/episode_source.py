"""The scenario of a stepped run's episodes: loaded once, then drawn anew from each episode's
case seed (testbed.campaign.cases.seeded_scenario). A `Simulation` and a Gymnasium vector
environment's worlds draw their episodes from one."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from testbed.campaign.cases import seeded_scenario
from testbed.errors import InputError
from testbed.scenario.loading import Scenario, load_mapping, parse
from testbed.scenario.yaml_reading import as_loaded


class EpisodeSource:
    """`scenario`: a name or path (with `overrides`), a raw mapping, or a loaded `Scenario`
    (which carries no sweep block, so no seed draws from it)."""

    def __init__(self, scenario: Scenario | str | Path | dict, overrides: list[str] = ()):
        self._mapping, self._source = None, ""
        if isinstance(scenario, Scenario):
            if overrides:
                raise InputError("overrides", "a loaded Scenario is already validated: pass overrides to load()")
            self.nominal = scenario
        elif isinstance(scenario, dict):
            if overrides:
                raise InputError("overrides", "apply overrides to the mapping itself")
            self._mapping = as_loaded(scenario)
            self.nominal = parse(self._mapping)
        else:
            self._mapping, self._source = load_mapping(str(scenario), list(overrides))
            self.nominal = parse(self._mapping, self._source)

    @property
    def disperses(self) -> bool:
        """Whether a seed draws anything: the scenario has a `sweep.dispersions` block."""
        sweep = (self._mapping or {}).get("sweep")
        return isinstance(sweep, dict) and bool(sweep.get("dispersions"))

    def scenario(self, seed: int | None = None) -> Scenario:
        """The validated scenario of an episode: with a case `seed` in [0, 2^32), the campaign
        dispersions (`sweep.dispersions`) drawn from it (the grid and `random:` fields keep their
        base values); without, the scenario as it is."""
        if seed is None:
            return self.nominal
        if self._mapping is None:
            raise InputError("seed", "a loaded Scenario carries no sweep block to draw from: "
                                     "pass the scenario's name, path or mapping")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**32:
            raise InputError("seed", f"must be an integer in [0, 2^32), got {seed!r}")
        return seeded_scenario(self._mapping, self._source, int(seed))

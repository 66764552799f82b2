"""The MEKF's NEES consistency campaign: attitude_nees_campaign over 50 noise seeds.

Run: .venv/bin/python bench/mekf_nees.py [n_seeds]
Prints the mean over the seeds of the final attitude NEES and the two-sided 95 % band of that
mean for a consistent filter, χ²(3 n) / n (validation 3 of docs/theory/attitude_determination.md),
and the mean over the seeds of each run's time-averaged NEES. The seeds are the campaign's
(`testbed campaign attitude_nees_campaign` draws the same ones from its sweep seed).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import scipy.stats

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout, uninstalled
import testbed  # noqa: E402
from testbed.campaign.cases import expand  # noqa: E402
from testbed.scenario.loading import resolve_path  # noqa: E402
from testbed.scenario.yaml_reading import read_yaml  # noqa: E402


def main(n: int) -> None:
    data = read_yaml(resolve_path("attitude_nees_campaign"))
    data["sweep"]["samples"] = n
    finals, means = [], []
    for case in expand(data):
        result = testbed.run(case.data)
        finals.append(result.metrics["final_attitude_nees"])
        means.append(result.metrics["attitude_nees_mean"])
    low, high = scipy.stats.chi2.ppf([0.025, 0.975], 3 * n) / n
    mean = float(np.mean(finals))
    print(f"seeds {n}: mean final NEES {mean:.3f}, 95 % band [{low:.3f}, {high:.3f}]: "
          f"{'inside' if low <= mean <= high else 'OUTSIDE'}")
    print(f"mean of the time-averaged NEES {np.mean(means):.3f} (3 for a consistent filter)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 50)

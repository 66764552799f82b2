"""The one progress bar of the command line (tqdm): on a terminal only, shown once a job has
taken more than 2 s, written to stderr so that stdout stays the result."""

from __future__ import annotations

import sys

from tqdm import tqdm


def progress_bar(label: str, total: float, unit: str) -> tqdm:
    """A bar for `total` units of work, hidden when stderr is not a terminal."""
    return tqdm(total=total, desc=label, unit=unit, delay=2.0, file=sys.stderr, leave=False,
                dynamic_ncols=True, disable=not sys.stderr.isatty(),
                bar_format="{desc} {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} {unit} [{elapsed}<{remaining}{postfix}]")


def advance_to(bar: tqdm, done: float, **postfix) -> None:
    """Move `bar` to `done` units (and show `postfix`, e.g. a count of failed cases)."""
    if postfix:
        bar.set_postfix(postfix, refresh=False)
    bar.update(done - bar.n)

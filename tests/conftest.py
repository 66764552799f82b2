"""Fixtures several test files share."""

import pytest

from campaign_cases import LOGGED_LAW


@pytest.fixture(scope="session")
def logged_law(tmp_path_factory) -> str:
    """The path of one plug-in file holding the law `test.logged` (tests/campaign_cases.py): a
    plug-in is imported once per process, so every test names this one file."""
    path = tmp_path_factory.mktemp("plugins") / "logged_law.py"
    path.write_text(LOGGED_LAW)
    return str(path)


@pytest.fixture(autouse=True)
def _own_working_folder(tmp_path, monkeypatch):
    """Every test runs in its own empty folder: a command's default output (runs/<file stem>.rrd)
    lands there, never in the checkout, and one test's trace never meets another's of the same
    file stem (a run refuses to replace the trace of another scenario file)."""
    monkeypatch.chdir(tmp_path)

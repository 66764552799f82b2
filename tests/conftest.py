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

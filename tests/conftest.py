"""Fixtures several test files share."""

import signal

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
# A suite started as a background job of a non-interactive shell inherits SIGINT and SIGQUIT
# ignored, and so would every command the tests start: the tests that send them would fail for
# the launcher's sake. Python leaves an inherited SIG_IGN as it is; give both their usual action.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
if signal.getsignal(signal.SIGQUIT) is signal.SIG_IGN:
    signal.signal(signal.SIGQUIT, signal.SIG_DFL)

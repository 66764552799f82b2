"""The documentation site (mkdocs.yml, docs/): it builds with --strict, so a broken link, a
missing page or anchor and an API reference to nothing fail; and every code block that a page
or README.md marks as runnable runs and ends with the exit status it says
(docs/validation.md, "The docs are tested").

A mark is the HTML comment `<!-- run -->` (or `<!-- run: exit N -->`) on the line before a
```bash or ```python fence. A bash block holds `testbed ...` command lines, each run through
`testbed.cli.main` in this process; every line must exit 0, the last one N when the mark says
so. A python block is run as a script. Each block runs in a fresh empty working folder, and
what plug-ins it registered is undone after it.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from testbed import registry
from testbed.plugins import discover
from testbed.cli import main

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md"]
MARK = re.compile(r"^<!-- run(?:: exit (\d+))? -->\n```(bash|python)\n(.*?)^```\n", re.M | re.S)
ANY_MARK = re.compile(r"^<!--\s*run\b", re.M)  # a mark at the start of a line


def mkdocs_build(config: Path, site: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config), "-d", str(site)],
                          cwd=config.parent, env=dict(os.environ, NO_MKDOCS_2_WARNING="1"),
                          capture_output=True, text=True, timeout=300)


def runnable_blocks() -> list:
    blocks = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for match in MARK.finditer(text):
            status, language, code = match.groups()
            line = text.count("\n", 0, match.start()) + 1
            blocks.append(pytest.param(language, code, int(status or 0), id=f"{page.relative_to(ROOT)}:{line}"))
    return blocks


def test_the_site_builds_strict_with_its_api_reference(tmp_path):
    done = mkdocs_build(ROOT / "mkdocs.yml", tmp_path / "site")
    assert done.returncode == 0, done.stderr[-4000:]
    reference = (tmp_path / "site" / "reference" / "index.html").read_text(encoding="utf-8")
    for name in ("testbed.api.run", "testbed.run_core.result.RunResult", "testbed.run_core.stage_contract.Law",
                 "testbed.run_core.stage_contract.StageContext", "testbed.run_core.plan.RunPlan",
                 "testbed.systems.registry.system", "testbed.plugins.load_plugins", "testbed.errors.InputError"):
        assert f'id="{name}"' in reference, name
    pages = {p.relative_to(ROOT / "docs").with_suffix("").as_posix() for p in (ROOT / "docs").rglob("*.md")}
    built = {p.parent.relative_to(tmp_path / "site").as_posix() for p in (tmp_path / "site").rglob("index.html")}
    assert {"." if p == "index" else p for p in pages} <= built


def test_the_strict_build_refuses_a_broken_link_and_anchor(tmp_path):
    """The project's validation settings on a one-page site: a link to a missing page and to a
    missing anchor each fail the build, named."""
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "index.md").write_text("# Home\n\n[gone](missing.md), [here](#nowhere)\n")
    config.update(docs_dir="docs", nav=["index.md"], plugins=["search"])
    (tmp_path / "mkdocs.yml").write_text(yaml.safe_dump(config))
    done = mkdocs_build(tmp_path / "mkdocs.yml", tmp_path / "site")
    assert done.returncode == 1, done.stderr[-4000:]
    warnings = [line for line in done.stderr.splitlines() if line.startswith("WARNING")]
    assert any("'missing.md'" in w for w in warnings) and any("'#nowhere'" in w for w in warnings), done.stderr[-4000:]


def test_every_run_mark_is_on_a_bash_or_python_block():
    """A mark the pattern does not match would silently run nothing."""
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        assert len(ANY_MARK.findall(text)) == len(MARK.findall(text)), page
    assert len(runnable_blocks()) >= 5


@pytest.mark.parametrize("language, code, status", runnable_blocks())
def test_a_runnable_block_runs(language, code, status, tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    discover()  # the built-ins once, before the snapshot: restoring it must not drop them
    saved = registry.snapshot()
    try:
        if language == "python":
            exec(compile(code, "<docs block>", "exec"), {"__name__": "__main__"})
            return
        commands = [argv for argv in (shlex.split(line, comments=True) for line in code.splitlines()) if argv]
        assert commands, "an empty block"
        for i, argv in enumerate(commands):
            assert argv[0] == "testbed", f"a runnable bash block holds testbed commands only: {argv}"
            wanted = status if i == len(commands) - 1 else 0
            got = main(argv[1:])
            _, err = capfd.readouterr()
            assert got == wanted, f"{shlex.join(argv)} exited {got}, the docs say {wanted}:\n{err}"
            if wanted == 2:
                assert len(err.splitlines()) == 1 and err.startswith("error: "), err
    finally:
        registry.restore(saved)

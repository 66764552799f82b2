"""`testbed sweep --resume` on a damaged output folder (issue 23). Damage a crash can cause, a
last line cut mid-write, is repaired: the line is dropped and its case runs again. Any other
damage, and an output path of the wrong kind (with or without --resume), is refused before
anything runs: exit 2, one stderr line naming the file, the folder left byte for byte as it
was."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest
import yaml

from test_hostile_input import assert_refused, cli  # noqa: F401  (cli: the in-process command fixture)
from test_sweep import BASE
from testbed.campaign.table import read_parquet
from testbed.cli import main

TABLE = "mini_sweep.csv"  # BASE's name


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> tuple[Path, Path]:
    """(scenario, folder) of a two-case planar campaign run to its end, uninterrupted."""
    folder = tmp_path_factory.mktemp("finished")
    scenario = folder / "mini.yaml"
    scenario.write_text(yaml.safe_dump(dict(BASE, sweep={"grid": {"pipeline.law.k": [1.0, 4.0]}})))
    assert main(["sweep", str(scenario), "--workers", "1", "--out", str(folder / "out")]) == 0
    return scenario, folder / "out"


def copy_of(finished, tmp_path: Path) -> Path:
    out = tmp_path / "out"  # outside the cli fixture's cwd, which must stay empty
    shutil.copytree(finished[1], out)
    return out


def files_in(folder: Path) -> dict[str, bytes | None]:
    """Every path below `folder` (hidden ones too) with its bytes (None: a directory)."""
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None for p in sorted(folder.rglob("*"))}


def edit_table(out: Path, edit) -> None:
    """Replace the table's lines (bytes, each with its b"\\r\\n") by edit(lines)."""
    path = out / TABLE
    path.write_bytes(b"".join(edit(path.read_bytes().splitlines(keepends=True))))


def csv_rows(path: Path) -> list[dict]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def edit_cell(out: Path, case: int, column: str, value: str) -> None:
    """Set one cell of case `case`'s row (the CSV rewritten whole, as csv writes it)."""
    path = out / TABLE
    with open(path, newline="") as handle:
        lines = list(csv.reader(handle))
    row = next(cells for cells in lines[1:] if cells[0] == str(case))
    row[lines[0].index(column)] = value
    with open(path, "w", newline="") as handle:
        csv.writer(handle).writerows(lines)


# each: the file named in the refusal, and what is done to the finished folder
DAMAGED = {
    # #4, #5 of the second round: whole rows of the right kinds that this campaign could not have written
    "status_bogus": (TABLE, lambda out: edit_cell(out, 0, "status", "bogus")),
    "status_with_nul": (TABLE, lambda out: edit_cell(out, 0, "status", "o\x00k")),
    "value_of_another_case": (TABLE, lambda out: edit_cell(out, 0, "pipeline.law.k", "4.0")),
    "value_changed": (TABLE, lambda out: edit_cell(out, 1, "pipeline.law.k", "99.0")),
    "seed_changed": (TABLE, lambda out: edit_cell(out, 0, "seed", "1")),
    "not_utf8": (TABLE, lambda out: edit_table(out, lambda lines: [
        lines[0], lines[1].replace(b",ok,", b",o\xff,"), *lines[2:]])),
    "field_over_128kB": (TABLE, lambda out: edit_table(out, lambda lines: [
        lines[0], lines[1].replace(b",ok,True,,", b",ok,True," + b"x" * 200_000 + b","), *lines[2:]])),
    "case_99": (TABLE, lambda out: edit_table(out, lambda lines: [*lines[:2], b"99" + lines[2][1:]])),
    "case_minus_1": (TABLE, lambda out: edit_table(out, lambda lines: [*lines[:2], b"-1" + lines[2][1:]])),
    "case_twice_other_cells": (TABLE, lambda out: edit_table(out, lambda lines: [
        *lines, lines[2].replace(b",pass", b",FAIL", 1)])),
    "row_of_other_cells": (TABLE, lambda out: edit_table(out, lambda lines: [  # a whole line: no crash made it
        lines[0], lines[1].replace(b",ok,", b",ok,extra,"), *lines[2:]])),
    "campaign_json_list": ("campaign.json", lambda out: (out / "campaign.json").write_text("[1, 2]")),
    "campaign_json_number": ("campaign.json", lambda out: (out / "campaign.json").write_text("3")),
    "campaign_json_string": ("campaign.json", lambda out: (out / "campaign.json").write_text('"x"')),
}


def a_directory(path: Path) -> None:
    shutil.rmtree(path) if path.is_dir() else path.unlink()
    path.mkdir()


WRONG_KIND = {
    "parquet_a_directory": ("mini_sweep.parquet", lambda out: a_directory(out / "mini_sweep.parquet")),
    "campaign_json_a_directory": ("campaign.json", lambda out: a_directory(out / "campaign.json")),
    "summary_json_a_directory": ("summary.json", lambda out: a_directory(out / "summary" / "summary.json")),
    "summary_rrd_a_directory": ("summary.rrd", lambda out: a_directory(out / "summary" / "summary.rrd")),
    "summary_a_file": ("summary", lambda out: (shutil.rmtree(out / "summary"), (out / "summary").write_text("x"))),
}


def refused_untouched(cli, finished, tmp_path, damage, field: str, name: str, *flags: str) -> None:
    out = copy_of(finished, tmp_path)
    damage(out)
    before = files_in(out)
    result = cli("sweep", finished[0], "--workers", "1", "--out", out, *flags)
    assert_refused(result, field, name)
    assert files_in(out) == before  # nothing run, written, removed or left half-written


@pytest.mark.parametrize("kind", DAMAGED)
def test_a_damaged_table_or_campaign_json_is_refused_and_left_as_it_is(cli, finished, tmp_path, kind):
    name, damage = DAMAGED[kind]
    refused_untouched(cli, finished, tmp_path, damage, "--resume", name, "--resume")


@pytest.mark.parametrize("flags", [["--resume"], []], ids=["resume", "fresh"])
@pytest.mark.parametrize("kind", WRONG_KIND)
def test_an_output_path_of_the_wrong_kind_is_refused_before_any_case_runs(cli, finished, tmp_path, kind, flags):
    name, damage = WRONG_KIND[kind]
    refused_untouched(cli, finished, tmp_path, damage, "--out", name, *flags)


def test_a_last_row_cut_inside_its_last_cell_runs_again_and_the_table_equals_an_uninterrupted_runs(
        cli, finished, tmp_path):
    """A kill in the middle of a write can cut the last line inside its last cell ("pass" to
    "pa"): the cell count is still right, but the line has no newline, so it is dropped."""
    out = copy_of(finished, tmp_path)
    table = out / TABLE
    table.write_bytes(table.read_bytes()[:-len(b"ss\r\n")])
    result = cli("sweep", finished[0], "--workers", "1", "--out", out, "--resume")
    assert result.code == 0 and "Traceback" not in result.err, result.err
    reference, resumed = csv_rows(finished[1] / TABLE), csv_rows(table)
    assert resumed[0] == reference[0]  # the whole row kept, its wall time too: not run again
    assert [{k: v for k, v in row.items() if k != "wall_s"} for row in resumed] == \
        [{k: v for k, v in row.items() if k != "wall_s"} for row in reference]
    assert [r["case"] for r in read_parquet(out / "mini_sweep.parquet")] == [0, 1]


@pytest.mark.parametrize("flags", [["--resume"], []], ids=["resume", "fresh"])
def test_a_case_trace_that_is_a_directory_is_refused_before_any_case_runs(cli, finished, tmp_path, flags):
    """#3: with --rrd, DIR/case0000.rrd a directory made case 0 an error row after the campaign
    ran; it is an output path of the wrong kind, refused like the table's."""
    refused_untouched(cli, finished, tmp_path, lambda out: (out / "case0000.rrd").mkdir(), "--out", "case0000.rrd",
                      "--rrd", *flags)

"""A campaign's table, kept as its cases finish: DIR/<stem>.csv and DIR/<stem>.parquet.

- The columns and their kinds (int, float, bool, str) are fixed before the first case runs,
  from the rows the validated cases will make (testbed.campaign.rows.expected_row).
- Each row is appended to the CSV and flushed the moment its case finishes, so an interrupted
  or killed campaign keeps every finished row (floats as repr: read back exactly).
- The Parquet file holds the same rows with their types; it is rewritten whole (to a temporary
  file renamed onto it, so it is always a complete file) every PARQUET_EVERY_S at most (and
  never more than 2 % of the time), and when the campaign ends or is interrupted.
- When the table closes, both files hold the rows sorted by case.
- DIR/campaign.json names the campaign and the fingerprint of its cases (base scenario, every
  case's seed and values): `--resume` continues only the same campaign, skipping the cases
  whose rows the CSV holds; a last line cut short by a crash is dropped and its case runs
  again; any other damage (not UTF-8, an unknown case or one given twice with other cells,
  a status this campaign does not write, a seed or value that is not its case's, a field
  over 128 kB, a campaign.json that is not an object) is refused before anything is written.
"""

from __future__ import annotations

import codecs
import csv
import hashlib
import io
import json
import time
from pathlib import Path

from testbed.recording.atomic_file import atomic_file, write_atomically
from testbed.errors import InputError, quoted, write_failed

PARQUET_EVERY_S = 5.0


def kind_of(value) -> str | None:
    """The column kind of one cell (None: an empty cell)."""
    if value is None:
        return None
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "int"
    if isinstance(value, float):
        return "float"
    return "str"


def merge_kinds(columns: dict[str, str | None], row: dict) -> None:
    """Add `row`'s cells to `columns` (name -> kind): a column holding ints and floats is a float
    column, one holding any other two kinds a str column."""
    for name, value in row.items():
        kind, known = kind_of(value), columns.get(name)
        if known is None:
            columns[name] = kind
        elif kind is not None and kind != known:
            columns[name] = "float" if {kind, known} == {"int", "float"} else "str"


def fingerprint(base: dict, cases) -> str:
    """sha256 of the base scenario and every case's index, seed and values."""
    text = json.dumps([base, [[c.index, c.seed, c.values] for c in cases]], sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


class CampaignTable:
    """`choices`: column -> the values a row may hold there (`status`); `cells`: case -> the
    cells its row must hold (its seed and values). A row read back for --resume that breaks
    either is damage."""

    def __init__(self, folder: Path, stem: str, columns: dict[str, str | None], identity: dict,
                 choices: dict[str, tuple] | None = None, cells: dict[int, dict] | None = None):
        self.folder = Path(folder)
        self.csv_path = self.folder / f"{stem}.csv"
        self.parquet_path = self.folder / f"{stem}.parquet"
        self.identity_path = self.folder / "campaign.json"
        checks = [k for k in columns if k.startswith("check:")]
        self.columns = {k: columns[k] or "str" for k in columns if k not in checks} | {k: "str" for k in checks}
        self.identity = identity
        self.choices, self.cells = choices or {}, cells or {}
        self.rows: dict[int, dict] = {}
        self._handle = self._writer = None
        self._parquet_at = 0.0
        self._parquet_cost = 0.0

    # --- opening ---------------------------------------------------------------------------
    def open(self, resume: bool) -> dict[int, dict]:
        """Start the table (a fresh one, or with `resume` the one this campaign left in the
        folder); returns the rows already finished, by case."""
        done = self.read(resume)
        self.start()
        return done

    def read(self, resume: bool) -> dict[int, dict]:
        """With `resume`, the rows this campaign left in the folder, by case ({} without);
        writes nothing. A last line without its newline (a write cut by a crash) is dropped, so
        its case runs again; any other damage is refused (InputError, README "Results that
        survive"), as is a path of the wrong kind for one of the table's files."""
        from testbed.recording.output_paths import output_path

        for path in (self.csv_path, self.parquet_path, self.identity_path):
            output_path(path)  # a directory there would fail only when it is written
        if resume and self.identity_path.exists():
            self._check_same_campaign()
            self.rows = self._read_csv() if self.csv_path.exists() else {}
        elif resume and self.csv_path.exists():
            raise InputError("--resume", f"{self.csv_path} has no campaign.json beside it: it cannot be "
                                         "told apart from another campaign's table")
        return dict(self.rows)

    def start(self) -> None:
        """Write campaign.json, the CSV of the rows read (without a cut-off last line) and the
        Parquet file, and open the CSV for the rows to come."""
        self.folder.mkdir(parents=True, exist_ok=True)
        write_atomically(self.identity_path, json.dumps(self.identity | {"columns": self.columns}, indent=1))
        self._rewrite_csv()
        self._handle = open(self.csv_path, "a", newline="")
        self._writer = csv.DictWriter(self._handle, fieldnames=list(self.columns), restval="", extrasaction="ignore")
        self._write_parquet()

    def _check_same_campaign(self) -> None:
        try:
            stored = json.loads(self.identity_path.read_text(encoding="utf-8"))
        except OSError as exc:
            raise _damaged(self.identity_path, f"cannot be read: {exc.strerror}") from None
        except (ValueError, RecursionError) as exc:  # not UTF-8, not JSON, nested too deep
            raise _damaged(self.identity_path, f"cannot be read: {exc}") from None
        if not isinstance(stored, dict):
            raise _damaged(self.identity_path, f"is not a JSON object: {quoted(stored)}")
        if stored.get("fingerprint") != self.identity["fingerprint"] or stored.get("columns") != self.columns:
            raise InputError("--resume", f"{self.folder} holds the table of another campaign (its scenario, "
                                         "seed or cases differ): give another --out, or leave out --resume")

    def _read_csv(self) -> dict[int, dict]:
        """The rows the CSV holds, by case; InputError for a line that is not one of this
        campaign's rows, or a case given twice with other cells."""
        path, count = self.csv_path, self.identity["cases"]
        lines = _whole_lines(path)
        if not lines or lines[0][1] != list(self.columns):
            raise _damaged(path, "does not have this campaign's columns")
        rows: dict[int, dict] = {}
        cells_of: dict[int, list[str]] = {}
        for number, cells in lines[1:]:
            row = self._parse(cells)
            if row is None:
                raise _damaged(path, f"line {number} is not a row of this campaign's columns")
            case = row["case"]
            if not 0 <= case < count:
                raise _damaged(path, f"line {number}: the campaign has no case {case} (0 ... {count - 1})")
            if cells_of.setdefault(case, cells) != cells:
                raise _damaged(path, f"line {number}: case {case} is there twice, with different cells")
            if why := self._not_of_its_case(row):
                raise _damaged(path, f"line {number}: {why}: not a row this campaign wrote")
            rows[case] = row
        return rows

    def _not_of_its_case(self, row: dict) -> str:
        """Why `row` cannot be one its case made ("" if it can): a cell outside its column's
        choices, or one its case fixes (read back as its column's kind holds it) that differs."""
        for name, allowed in self.choices.items():
            if name in row and row[name] not in allowed:
                return f"{name} {quoted(row[name])} is not one of {', '.join(allowed)}"
        for name, value in self.cells.get(row["case"], {}).items():
            if name in self.columns and not _same(row.get(name), _read_back(value, self.columns[name])):
                return f"{name} {quoted(row.get(name))} is not case {row['case']}'s {quoted(value)}"
        return ""

    def _parse(self, cells: list[str]) -> dict | None:
        """A CSV line as a typed row; None for a line of other cells or kinds."""
        if len(cells) != len(self.columns):
            return None
        try:
            row = {name: _typed(cell, kind) for (name, kind), cell in zip(self.columns.items(), cells)}
        except ValueError:
            return None
        return row if isinstance(row.get("case"), int) and isinstance(row.get("passed"), bool) else None

    # --- rows as they finish ---------------------------------------------------------------
    def append(self, row: dict) -> None:
        """Record a finished case: its CSV line now, the Parquet file when it is due."""
        try:
            self._writer.writerow(_csv_cells(row))
            self._handle.flush()
        except OSError as exc:  # a full disk: the rows before stay whole, a cut-off line is dropped on --resume
            self._close_handle()
            raise write_failed(self.csv_path, exc) from None
        self.rows[row["case"]] = row
        now = time.monotonic()
        if now - self._parquet_at >= max(PARQUET_EVERY_S, 50.0 * self._parquet_cost):
            self._write_parquet()

    def close(self) -> list[dict]:
        """Both files sorted by case, complete; returns the rows in case order."""
        self._close_handle()
        self._rewrite_csv()
        self._write_parquet()
        return [self.rows[k] for k in sorted(self.rows)]

    def _close_handle(self) -> None:
        """Close the appended CSV; what a failed write left in its buffer is written if it can be, else dropped."""
        handle, self._handle = self._handle, None
        if handle is not None:
            try:
                handle.close()
            except OSError:
                pass

    def _rewrite_csv(self) -> None:
        with atomic_file(self.csv_path) as handle:
            writer = csv.DictWriter(handle, fieldnames=list(self.columns), restval="", extrasaction="ignore")
            writer.writeheader()
            for key in sorted(self.rows):
                writer.writerow(_csv_cells(self.rows[key]))

    def _write_parquet(self) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        start = time.monotonic()
        types = {"int": pa.int64(), "float": pa.float64(), "bool": pa.bool_(), "str": pa.string()}
        schema = pa.schema([(name, types[kind]) for name, kind in self.columns.items()])
        rows = [{name: _cell_for(row.get(name), kind) for name, kind in self.columns.items()}
                for _, row in sorted(self.rows.items())]
        with atomic_file(self.parquet_path, binary=True) as handle:
            pq.write_table(pa.Table.from_pylist(rows, schema=schema), handle)
        self._parquet_at = time.monotonic()
        self._parquet_cost = self._parquet_at - start


def read_parquet(path: Path) -> list[dict]:
    """The rows of a campaign's Parquet table, in case order."""
    import pyarrow.parquet as pq

    return pq.read_table(path).to_pylist()


def _whole_lines(path: Path) -> list[tuple[int, list[str]]]:
    """(line number, cells) of every CSV record of `path` but a last one a crash cut short (no
    newline at its end: every record is written whole with one); InputError for a file that
    is not UTF-8 or a field over csv.field_size_limit() (128 kB)."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise _damaged(path, f"cannot be read: {exc.strerror}") from None
    cut = not data.endswith(b"\n")
    try:  # a cut line may end in half a character
        text = codecs.getincrementaldecoder("utf-8")().decode(data, final=not cut)
    except UnicodeDecodeError as exc:
        raise _damaged(path, f"is not UTF-8 text (byte {exc.start})") from None
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        lines = [(reader.line_num, cells) for cells in reader]
    except csv.Error as exc:
        raise _damaged(path, f"line {reader.line_num}: {exc}") from None
    return lines[:-1] if cut else lines


def _damaged(path: Path, why: str) -> InputError:
    """The refusal of a damaged file in the folder to resume: `--resume: <file>: <why>` (the
    path quoted, so that a long one keeps its file name)."""
    return InputError("--resume", f"{quoted(str(path))}: {why}")


def _typed(cell: str, kind: str):
    if cell == "":
        return "" if kind == "str" else None
    if kind == "int":
        return int(cell)
    if kind == "float":
        return float(cell)
    if kind == "bool":
        if cell not in ("True", "False"):
            raise ValueError(cell)
        return cell == "True"
    return cell


def _read_back(value, kind: str):
    """`value` as the CSV gives it back in a column of `kind` (written by _csv_cells, read by _typed)."""
    if value is None:
        return _typed("", kind)
    return _typed(str(_csv_cells({"v": value})["v"]), kind)


def _same(a, b) -> bool:
    """Equal cells; two NaN floats are the same cell."""
    return a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)


def _cell_for(value, kind: str):
    """A row's value as its column's type holds it (an int in a float column as a float)."""
    if value is None:
        return None
    if kind == "float":
        return float(value)
    if kind == "str" and not isinstance(value, str):
        return str(value)
    return value


def _csv_cells(row: dict) -> dict:
    return {k: repr(v) if isinstance(v, float) else v for k, v in row.items()}

"""The error types a command ends with besides a run's own outcome: bad user input (scenario
fields, CLI options; exit 2) and output that could not be written (exit 1); how they quote values."""

import contextlib
import dataclasses
import math
import reprlib

import numpy as np

from testbed.exit_guard import ExitCalled
from testbed.interrupts import from_a_signal


class _Repr(reprlib.Repr):
    def repr_int(self, x, level):
        try:
            return super().repr_int(x, level)
        except ValueError:  # more than 4300 decimal digits: Python will not write it out
            return f"<an integer of {x.bit_length()} bits>"


_REPR = _Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict, _REPR.maxstring, _REPR.maxother, _REPR.maxlong = 3, 6, 4, 60, 60, 40
QUOTE_LIMIT = 80


def quoted(value) -> str:
    """A short repr of a user's value for an error message: at most QUOTE_LIMIT characters,
    whatever its size or nesting (reprlib never expands a huge or shared structure)."""
    text = _REPR.repr(value)
    return text if len(text) <= QUOTE_LIMIT else text[: QUOTE_LIMIT - 3] + "..."


WORD_LIMIT = 96  # a path or a name in a message; a user's longer word is cut


def one_line(text) -> str:
    """`text` on one printable line: whitespace runs become one space, other control and
    non-printable characters (terminal escapes, line separators) their escaped form, and any
    word (a value, a key, a path) longer than WORD_LIMIT characters cut short."""
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in " ".join(str(text).split()))
    return " ".join(w if len(w) <= WORD_LIMIT else w[: WORD_LIMIT - 3] + "..." for w in text.split(" "))


ERROR_LIMIT = 300  # characters of a run's or a campaign row's error


def error_line(text) -> str:
    """`text` as one printable line (`one_line`) of at most ERROR_LIMIT characters: a run's or
    a campaign row's error, whatever a stage's message held."""
    line = one_line(str(text)[: 100 * ERROR_LIMIT])  # enough for the line: megabytes cost no time
    return line if len(line) <= ERROR_LIMIT else line[: ERROR_LIMIT - 3] + "..."


def described(exc: BaseException) -> str:
    """What a user's code raised, for an error message: `Type: message`; `it exited the process
    (sys.exit(0))` for sys.exit or os._exit (testbed.exit_guard); the type alone, said so, when
    its message cannot be made (a __str__ that raises)."""
    if isinstance(exc, SystemExit):
        call = "os._exit" if isinstance(exc, ExitCalled) else "sys.exit"
        return f"it exited the process ({call}({quoted(exc.code)}))"
    name = type(exc).__name__
    try:
        message = str(exc)
    except BaseException as failure:  # noqa: BLE001  (whatever a hostile __str__ raises)
        if from_a_signal(failure):
            raise
        return f"{name} (its message cannot be printed)"
    return f"{name}: {message}" if message else name


class InputError(Exception):
    """Bad input: names the offending field and why; the CLI prints it on one line, exit 2."""

    def __init__(self, field: str, reason: str):
        self.field = one_line(field)  # a user's key may be part of it
        self.reason = one_line(reason)  # one line, whatever the user's value held
        super().__init__(f"{self.field}: {self.reason}")


class WriteFailed(Exception):
    """Output that could not be written (a full disk, a stdout on /dev/full): names the file and
    the system's reason; the CLI prints it on one line, exit 1."""

    def __init__(self, path, reason: str):
        self.path = one_line(path)
        self.reason = one_line(reason)
        super().__init__(f"{self.path}: {self.reason}")


def write_failed(path, exc: OSError) -> WriteFailed:
    """The WriteFailed of an OSError met writing `path` (its strerror, "No space left on device")."""
    return WriteFailed(path, exc.strerror or str(exc))


@contextlib.contextmanager
def refused_as(field: str, name: str = "", params: dict | None = None):
    """Arithmetic and linear-algebra failures while building from the user's parameters (an
    overflow, a failed factorisation) become InputError(field), the built type `name` leading
    the reason: parameters too extreme to build are bad input, not a crash. `params` (path ->
    the parameters built from, a dataclass, mapping, list or number): the reason names the most
    extreme of their numbers, the likeliest cause, in plain words."""
    try:
        yield
    except (ArithmeticError, np.linalg.LinAlgError) as exc:
        lead = f"{name}: " if name else ""
        extreme = most_extreme_number(params or {})
        if extreme is None:
            raise InputError(field, f"{lead}its parameters cannot be built: {type(exc).__name__}: {exc}") from None
        path, value = extreme
        built = f"{field} ({name})" if name else field
        why = one_line(exc) or type(exc).__name__
        raise InputError(path, f"{value:g} is too {'large' if abs(value) > 1 else 'small'} to build {built} "
                         f"from: its arithmetic leaves double precision ({why})") from None


EXTREME_DECADES = 15  # a float beyond 1e15 or below 1e-15 in magnitude is a suspect when arithmetic fails


def most_extreme_number(params: dict) -> tuple[str, float] | None:
    """(path, value) of the nonzero float furthest from 1 in order of magnitude in `params` (path ->
    dataclass, mapping, list or number, searched through), if it is at least EXTREME_DECADES from 1;
    else None (integers are counts and seeds, not magnitudes)."""
    best, found = float(EXTREME_DECADES), None
    stack = list(params.items())
    while stack:
        path, value = stack.pop()
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            stack += [(f"{path}.{f.name}", getattr(value, f.name)) for f in dataclasses.fields(value)]
        elif isinstance(value, dict):
            stack += [(f"{path}.{k}", v) for k, v in value.items()]
        elif isinstance(value, (list, tuple)):
            stack += [(f"{path}[{i}]", v) for i, v in enumerate(value)]
        elif isinstance(value, float) and value != 0 and math.isfinite(value):
            size = abs(math.log10(abs(value)))
            if size >= best:
                best, found = size, (path, float(value))
    return found

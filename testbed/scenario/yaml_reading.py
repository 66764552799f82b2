"""Reading scenario YAML strictly: safe_load semantics (no Python tags are ever executed) plus
the refusals a hostile or mistaken file needs, each an InputError naming the file and line:

- a file over MAX_FILE_BYTES or not UTF-8 text;
- a key given twice in one mapping (YAML's "last one wins" would silently drop a value);
- anchors and aliases (`&a`, `*a`): they let a few lines stand for an exponentially large
  document, and a scenario has no use for them;
- nesting deeper than MAX_DEPTH;
- an integer of more digits than Python reads from text (4300).

YAML 1.1 reads `1e-9` (no dot) as a string; scientists write it, so it is read as a float.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import yaml

from testbed.errors import InputError

MAX_FILE_BYTES = 1_000_000
MAX_DEPTH = 20


class _Loader(yaml.SafeLoader):
    depth = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            mark = self.peek_event().start_mark
            raise yaml.constructor.ConstructorError(None, None, "aliases (*name) are not allowed", mark)
        if self.depth >= MAX_DEPTH:
            raise yaml.constructor.ConstructorError(None, None, f"nested deeper than {MAX_DEPTH} levels",
                                                    self.peek_event().start_mark)
        self.depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1

    def construct_yaml_int(self, node):
        try:
            return super().construct_yaml_int(node)
        except ValueError:  # Python's limit on the digits of a decimal integer read from text
            raise yaml.constructor.ConstructorError(
                None, None, f"an integer of more than {sys.get_int_max_str_digits()} digits", node.start_mark) from None

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                duplicate = key in seen
            except TypeError:
                raise yaml.constructor.ConstructorError(None, None, "a mapping key must be a plain value",
                                                        key_node.start_mark) from None
            if duplicate:
                raise yaml.constructor.ConstructorError(None, None, f"key {key!r} is given twice",
                                                        key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep)


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _Loader.construct_mapping)
_Loader.add_constructor("tag:yaml.org,2002:int", _Loader.construct_yaml_int)
_FLOAT = re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                    |\.[0-9_]+(?:[eE][-+][0-9]+)?
                    |[-+]?\.(?:inf|Inf|INF)
                    |\.(?:nan|NaN|NAN))$""", re.X)
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))


def as_loaded(data, path: str = "", depth: int = 0):
    """`data` (a mapping built in Python, or read by another YAML reader) with every string that
    this loader would have read as a number made that number, as if it had come from a file:
    PyYAML's `safe_load` reads `1e-4` (no dot) as the string '1e-4'. Other values as they are.
    Nesting deeper than MAX_DEPTH (a mapping that contains itself too) is refused as in a file."""
    if depth >= MAX_DEPTH:  # the file loader's rule: the top mapping is level 0
        raise InputError(path or "scenario", f"nested deeper than {MAX_DEPTH} levels "
                                             "(or a mapping or list that contains itself)")
    if isinstance(data, dict):
        return {key: as_loaded(value, _joined(path, key), depth + 1) for key, value in data.items()}
    if isinstance(data, (list, tuple)):
        return [as_loaded(value, _joined(path, index), depth + 1) for index, value in enumerate(data)]
    if isinstance(data, str) and _FLOAT.match(data):
        return _Loader("").construct_yaml_float(yaml.ScalarNode("tag:yaml.org,2002:float", data))
    return data


def _joined(path: str, key) -> str:
    """The dotted path of item `key` below `path` (cut to its first 80 characters)."""
    return (f"{path}.{key}" if path else str(key))[:80]


def yaml_load(text: str, where: str):
    """The YAML document in `text`; InputError(where, ...) with the line of anything refused."""
    try:
        return yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or "syntax error"
        raise InputError(where, f"not a valid scenario YAML{line}: {problem}") from None
    except RecursionError:
        raise InputError(where, f"nested too deeply (more than {MAX_DEPTH} levels)") from None


def read_yaml(path: Path) -> dict:
    """A scenario file's top-level mapping (see module doc for what is refused)."""
    where = str(path)
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:  # refused without reading it
            raise InputError(where, f"is {size} bytes; a scenario file may hold at most {MAX_FILE_BYTES}")
        with path.open("rb") as handle:
            raw = handle.read(MAX_FILE_BYTES + 1)  # a file that grows meanwhile is still capped
    except OSError as exc:
        raise InputError(where, f"cannot read the file: {exc.strerror}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise InputError(where, f"holds more than {MAX_FILE_BYTES} bytes; a scenario file may hold at most that")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(where, f"is not UTF-8 text (byte {exc.start})") from None
    data = yaml_load(text, where)
    if not isinstance(data, dict):
        raise InputError(where, "a scenario file must be a YAML mapping")
    return data

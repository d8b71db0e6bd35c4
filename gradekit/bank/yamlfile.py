"""YAML reading with line numbers, built on PyYAML's SafeLoader (no arbitrary object construction), in C
(libyaml) where PyYAML has it."""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path

import yaml

from gradekit.errors import ProblemError


class LineDict(dict):
    """A mapping that remembers the line of each key (``lines``) and of itself (``line``)."""

    line: int = 0

    def __init__(self) -> None:
        super().__init__()
        self.lines: dict = {}


class LineList(list):
    """A sequence that remembers the line of each item."""

    line: int = 0

    def __init__(self) -> None:
        super().__init__()
        self.lines: list[int] = []


MAX_BYTES = 2_000_000  # the largest bank file is ~20 kB
MAX_DEPTH = 60  # nesting of mappings and sequences
MAX_NODES = 200_000  # nodes after expanding every alias (a billion-laughs file has 10**9)


_SAFE = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml's parser where PyYAML has it, same constructor


class _Loader(_SAFE):
    """SafeLoader that records node lines, rejects duplicate keys and bounds aliases.

    Every alias re-uses its anchor's whole subtree, so a few lines can stand for 10**9 nodes; the
    composed document is measured with aliases expanded (memoised per node, so measuring is
    linear) and refused above `MAX_NODES`, before anything is constructed. Nesting is bounded
    before composing (`_check_depth`).
    """

    def get_single_node(self):
        node = super().get_single_node()
        if node is not None:
            _measure(node)
        return node


def safe_data(text: str, path: Path | str, expected: str):
    """The plain data (mappings, lists, scalars) of the YAML *text* of file *path*, as `yaml.safe_load` makes
    it, read by libyaml where PyYAML has it; nesting bounded as `load` bounds it.

    Raises:
        ProblemError: the text is not YAML or nests too deep ("expected *expected*, got …", one line, naming
            *path* and the line).
    """
    try:
        _check_depth(text)
        return yaml.load(text, Loader=_SAFE)  # noqa: S506 - SafeLoader's constructor (CSafeLoader is its C parser)
    except yaml.YAMLError as exc:
        raise _refused(exc, path, expected) from None


def _refused(exc: yaml.YAMLError, path: Path | str, expected: str, hint: str = "") -> ProblemError:
    """*exc* as one line naming *path* and the line it points at. PyYAML's message may run over lines, and
    libyaml's own nesting limit (some versions have one, at 1,000 levels) speaks before `_check_depth`."""
    mark = getattr(exc, "problem_mark", None)
    problem = " ".join((getattr(exc, "problem", None) or str(exc)).split())
    return ProblemError(f"expected {expected}, got {problem}{hint}", path=str(path),
                        line=mark.line + 1 if mark else None)


def _check_depth(text: str) -> None:
    """Raise a `ComposerError` at the first collection nested deeper than `MAX_DEPTH`.

    Read from the parser's events, which libyaml makes without recursing: composing recurses once per
    level in C, where a file of a million ``[`` would overflow the stack instead of raising.
    """
    depth = 0
    for event in yaml.parse(text, Loader=_SAFE):
        if isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            depth += 1
            if depth > MAX_DEPTH:
                raise yaml.composer.ComposerError(None, None, f"nesting deeper than {MAX_DEPTH} levels",
                                                  event.start_mark)
        elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            depth -= 1


def _measure(root: yaml.Node) -> None:
    """Raise a `ComposerError` when *root*, aliases expanded, has more than `MAX_NODES` nodes."""
    sizes: dict[int, int] = {}
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, children_done = stack.pop()
        if id(node) in sizes:
            continue
        if isinstance(node, yaml.ScalarNode):
            sizes[id(node)] = 1
            continue
        kids = [x for pair in node.value for x in pair] if isinstance(node, yaml.MappingNode) else list(node.value)
        if not children_done:
            stack.append((node, True))
            stack.extend((k, False) for k in kids if id(k) not in sizes)
            continue
        total = 1 + sum(sizes.get(id(k), 1) for k in kids)
        if total > MAX_NODES:
            raise yaml.composer.ComposerError(
                None,
                None,
                f"more than {MAX_NODES:,} values once its aliases (*name) are expanded",
                node.start_mark,
            )
        sizes[id(node)] = total


def _mapping(loader: _Loader, node: yaml.MappingNode) -> LineDict:
    loader.flatten_mapping(node)
    out = LineDict()
    out.line = node.start_mark.line + 1
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        if key in out:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r} (first on line {out.lines[key]})", key_node.start_mark
            )
        out[key] = loader.construct_object(value_node, deep=True)
        out.lines[key] = key_node.start_mark.line + 1
    return out


def _sequence(loader: _Loader, node: yaml.SequenceNode) -> LineList:
    out = LineList()
    out.line = node.start_mark.line + 1
    for item in node.value:
        out.append(loader.construct_object(item, deep=True))
        out.lines.append(item.start_mark.line + 1)
    return out


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)
_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _sequence)


def load(path: Path | str) -> LineDict:
    """Read a YAML mapping with line numbers; raise `ProblemError` naming the file and line."""
    path = Path(path)
    try:
        text = _read_regular(path).decode("utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProblemError(
            f"expected a readable UTF-8 YAML file, got {exc.__class__.__name__}: {exc}", path=str(path)
        ) from None
    try:
        _check_depth(text)
        data = yaml.load(text, Loader=_Loader)  # noqa: S506 - _Loader constructs as SafeLoader does (SafeConstructor)
    except yaml.YAMLError as exc:
        raise _refused(exc, path, "valid YAML", _flow_hint(text, getattr(exc, "problem_mark", None))) from None
    if not isinstance(data, dict):
        raise ProblemError(f"expected a mapping at the top, got {type(data).__name__}", path=str(path), line=1)
    return data


def is_regular(path: Path) -> bool:
    """Whether *path* (links followed) is a regular file: a FIFO, socket or device is never opened to be
    read, where reading a FIFO would wait for a writer forever."""
    try:
        return stat.S_ISREG(path.stat().st_mode)
    except OSError:
        return False


def _read_regular(path: Path) -> bytes:
    """The bytes of the regular file *path*, at most `MAX_BYTES` of them.

    Opened without blocking (opening a FIFO to read would wait for a writer) and checked to be a
    regular file on the open descriptor, so a file swapped for a FIFO in between is refused too.
    """
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    with os.fdopen(fd, "rb") as handle:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise ProblemError(f"expected a regular YAML file, got {_kind(info.st_mode)}", path=str(path))
        if info.st_size > MAX_BYTES:
            raise ProblemError(f"expected a YAML file under {MAX_BYTES:,} bytes, got {info.st_size:,}", path=str(path))
        return handle.read(MAX_BYTES + 1)


def _kind(mode: int) -> str:
    """What a file that is not a regular file is, in words."""
    for test, name in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device")):
        if test(mode):
            return name
    return "a special file"


def _flow_hint(text: str, mark) -> str:
    """A hint for the commonest slip in a flow mapping: a value with a comma or brackets unquoted."""
    if mark is None:
        return ""
    lines = text.splitlines()
    line = lines[mark.line] if mark.line < len(lines) else ""
    if "{" in line and re.search(r":\s*[^\s\"'{\[][^,}]*\[[^\]]*,", line):
        return (" (in a flow mapping {…} a comma ends the value and brackets start a list: quote a value "
                "such as \"F[1,2].mag\")")
    return ""

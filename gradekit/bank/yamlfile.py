"""YAML reading with line numbers, built on PyYAML's SafeLoader (no arbitrary object construction)."""

from __future__ import annotations

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


class _Loader(yaml.SafeLoader):
    """SafeLoader that records node lines and rejects duplicate keys."""


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
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProblemError(
            f"expected a readable UTF-8 YAML file, got {exc.__class__.__name__}: {exc}", path=str(path)
        ) from None
    try:
        data = yaml.load(text, Loader=_Loader)  # noqa: S506 - _Loader is a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark else None
        problem = getattr(exc, "problem", None) or str(exc)
        raise ProblemError(f"expected valid YAML, got {problem}", path=str(path), line=line) from None
    if not isinstance(data, dict):
        raise ProblemError(f"expected a mapping at the top, got {type(data).__name__}", path=str(path), line=1)
    return data

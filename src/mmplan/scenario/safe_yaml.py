"""Bounded reading of untrusted YAML and bounded rendering of the values it holds.

* :func:`load`: YAML text -> Python objects (safe constructors; duplicate keys refused). The
  structure is checked on the parser's event stream before any node or object is built:
  more than :data:`MAX_DEPTH` nested collections, more than :data:`MAX_NODES` values with
  aliases expanded (an alias bomb), recursive aliases and a sequence or mapping used as a
  mapping key raise :class:`StructureError` with the key path, in time linear in the text;
* :func:`short_repr`, :func:`clip`: a value in at most :data:`MAX_SHOWN` characters, a message
  on one line of at most :data:`MAX_MESSAGE`, computed without building the full ``repr``.
"""

from __future__ import annotations

import math
import re
import reprlib
from dataclasses import dataclass
from typing import Any

import yaml

#: Deepest nesting of collections (after alias expansion); a scenario needs about 6.
MAX_DEPTH = 32
#: Most values (scalars and collections, every alias expanded) in one document.
MAX_NODES = 100_000
#: Longest rendering of a value in a message.
MAX_SHOWN = 200
#: Longest message (one line).
MAX_MESSAGE = 500

#: libyaml's parser when available (fast on large inputs); PyYAML's pure-Python one otherwise.
_BaseLoader: type[Any] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class StructureError(Exception):
    """YAML whose structure is refused; ``path`` is the key path where it was found."""

    def __init__(self, path: str, problem: str) -> None:
        super().__init__(f"{path}: {problem}" if path else problem)
        self.path = path
        self.problem = problem


def load(text: str) -> Any:
    """Check the structure of ``text``, then load it with safe constructors.

    Raises:
        StructureError: too deep, too many values, a recursive alias or a collection as a key.
        yaml.YAMLError: malformed YAML or a duplicate key.
    """
    _check_structure(text)
    return yaml.load(text, Loader=_UniqueKeyLoader)


class _ShortRepr(reprlib.Repr):
    """``reprlib`` limits plus integers shown by their size when long (no 4300-digit error)."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel, self.maxlist, self.maxtuple, self.maxdict = 3, 6, 6, 4
        self.maxstring, self.maxother, self.maxlong = 80, 80, 40

    def repr_int(self, x: int, level: int) -> str:
        if x.bit_length() > 128:
            return f"<integer of {int(x.bit_length() * math.log10(2)) + 1} digits>"
        return super().repr_int(x, level)


_SHORT = _ShortRepr()


def short_repr(value: Any, limit: int = MAX_SHOWN) -> str:
    """``repr(value)`` cut to ``limit`` characters (with ``...``), never built in full."""
    try:
        text = _SHORT.repr(value)
    except Exception:  # a hostile __repr__; scenario values are plain YAML types
        text = f"<{type(value).__name__}>"
    return clip(text, limit)


def clip(text: str, limit: int = MAX_MESSAGE) -> str:
    """``text`` on one line (line breaks and tabs escaped) and at most ``limit`` characters."""
    if len(text) > 4 * limit:
        text = text[:4 * limit]
    text = text.replace("\r", "\\r").replace("\n", "\\n").replace("\t", " ")
    text = "".join(c if c.isprintable() else "?" for c in text)
    return text if len(text) <= limit else text[:limit - 3] + "..."


@dataclass
class _Frame:
    """An open collection while the event stream is read."""

    mapping: bool
    anchor: str | None
    start: int  # values counted before this collection
    height: int = 1  # collections nested in it, itself included
    key: str | None = None  # mapping: the key whose value is being read
    expect_key: bool = True
    index: int = 0  # sequence: index of the next item


@dataclass(frozen=True)
class _Anchor:
    size: int  # values with aliases expanded
    height: int  # 0 for a scalar
    scalar: str | None  # the text of an anchored scalar (usable as a key)


def _where(event: yaml.Event) -> str:
    mark = event.start_mark
    return f"line {mark.line + 1}, column {mark.column + 1}" if mark else "unknown position"


def _path(stack: list[_Frame]) -> str:
    out = ""
    for frame in stack:
        if frame.mapping and not frame.expect_key and frame.key is not None:
            key = frame.key if len(frame.key) <= 40 else short_repr(frame.key, 40)
            out += f".{key}" if out else key
        elif not frame.mapping:
            out += f"[{frame.index}]"
    return out


def _check_structure(text: str) -> None:
    """Refuse deep nesting, alias bombs, recursive aliases and collections used as keys.

    Reads only parser events (no nodes, no objects); aliases are counted by the size and
    height their anchor had, so the cost is linear in the text whatever the expansion.
    """
    loader = _BaseLoader(text)
    stack: list[_Frame] = []
    anchors: dict[str, _Anchor] = {}
    count = 0
    try:
        while loader.check_event():
            event = loader.get_event()
            if isinstance(event, yaml.CollectionEndEvent):
                frame = stack.pop()
                if frame.anchor is not None:
                    anchors[frame.anchor] = _Anchor(count - frame.start, frame.height, None)
                if stack:
                    stack[-1].height = max(stack[-1].height, frame.height + 1)
                    _advance(stack[-1], None)
                continue
            if not isinstance(event, yaml.NodeEvent):
                continue  # stream and document start / end
            parent = stack[-1] if stack else None
            target: _Anchor | None = None
            is_key = parent is not None and parent.mapping and parent.expect_key

            def refuse(problem: str, at: yaml.Event = event) -> StructureError:
                return StructureError(_path(stack), f"{problem} ({_where(at)})")

            if isinstance(event, yaml.CollectionStartEvent):
                if is_key:
                    kind = "mapping" if isinstance(event, yaml.MappingStartEvent) else "sequence"
                    raise refuse(f"a {kind} used as a mapping key; keys must be names")
                size, depth = 1, len(stack) + 1
            elif isinstance(event, yaml.AliasEvent):
                name = str(event.anchor)
                if any(f.anchor == name for f in stack):
                    raise refuse(f"alias *{short_repr(name, 40)[1:-1]} refers to a collection "
                                 "that contains it (recursive aliases are not allowed)")
                target = anchors.get(name)
                if target is None:  # undefined: the composer reports it with its position
                    target = _Anchor(1, 0, name)
                if is_key and target.scalar is None:
                    raise refuse(f"alias *{short_repr(name, 40)[1:-1]} of a collection used as "
                                 "a mapping key; keys must be names")
                size, depth = target.size, len(stack) + target.height
            else:
                size, depth = 1, len(stack)
            count += size
            if count > MAX_NODES:
                raise refuse(f"more than {MAX_NODES} values with aliases expanded; a scenario "
                             "holds a few hundred")
            if depth > MAX_DEPTH:
                raise refuse(f"nested more than {MAX_DEPTH} levels deep")
            if isinstance(event, yaml.CollectionStartEvent):
                stack.append(_Frame(isinstance(event, yaml.MappingStartEvent), event.anchor,
                                    count - 1))
                continue
            key: str | None = None
            if isinstance(event, yaml.ScalarEvent):
                if event.anchor is not None:
                    anchors[event.anchor] = _Anchor(1, 0, event.value)
                key = event.value
            elif target is not None:
                key = target.scalar
                if parent is not None:
                    parent.height = max(parent.height, target.height + 1)
            if parent is not None:
                _advance(parent, key)
    except yaml.MarkedYAMLError as err:
        # libyaml (PyYAML >= 6.0.4 with the C scanner) refuses deep flow nesting itself while
        # scanning ahead, before the events reach the depth test above: the same refusal
        if "maximum nesting depth" not in str(err.problem):
            raise
        mark = err.problem_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "unknown position"
        raise StructureError(_path(stack), f"nested more than {MAX_DEPTH} levels deep ({where})"
                             ) from None
    finally:
        loader.dispose()


def _advance(frame: _Frame, key: str | None) -> None:
    """A value (or key) of ``frame`` has been read."""
    if not frame.mapping:
        frame.index += 1
    elif frame.expect_key:
        frame.key, frame.expect_key = key, False
    else:
        frame.expect_key = True


class _UniqueKeyLoader(_BaseLoader):
    """Safe YAML loader that rejects duplicate keys (libyaml's parser when available)."""


def _mapping(loader: yaml.SafeLoader, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
    seen: set[Any] = set()
    for key_node, _ in node.value:
        if key_node.tag == _MERGE_TAG:  # "<<: *defaults": merged (and overridden) by PyYAML
            continue
        key = loader.construct_object(key_node, deep=deep)
        try:
            duplicate = key in seen
        except TypeError:  # refused earlier by _check_structure; kept as a guard
            raise yaml.constructor.ConstructorError(
                None, None, "a mapping key must be a name", key_node.start_mark) from None
        if duplicate:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {short_repr(key, 80)}", key_node.start_mark)
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


_MERGE_TAG = "tag:yaml.org,2002:merge"
_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)

#: Floats as YAML 1.2 writes them: PyYAML (YAML 1.1) reads ``1e-3`` and ``1e300`` as strings
#: (it wants a dot: ``1.0e-3``), and a new user's ``tolerance: 1e-3`` was refused as "not a
#: number".
_FLOAT_12 = re.compile(
    r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9][0-9_]*)[eE][-+]?[0-9]+$"
)
_UniqueKeyLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_12, list("-+0123456789."))

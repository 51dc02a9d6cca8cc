"""Reading scenario text and reporting its errors as one line each.

* :func:`parse_yaml`: YAML text -> mapping (safe loader; duplicate keys and malformed YAML are
  errors with line and column);
* :func:`validation_error`: the first error of a pydantic ``ValidationError`` -> a
  :class:`ScenarioError` whose message is ``<source>: <key path>: <problem>``, with the key
  path written ``obstacles[1].radius`` (list indices in brackets, union tags dropped).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import yaml
from pydantic import ValidationError

from mmplan.errors import InputError


class ScenarioError(InputError):
    """Invalid scenario (exit code 2); ``source`` is the file or built-in name."""

    def __init__(self, source: str, field: str, problem: str) -> None:
        super().__init__(field, problem)
        self.source = source

    def __str__(self) -> str:
        inner = f"{self.field}: {self.problem}" if self.field else self.problem
        return f"{self.source}: {inner}"


def parse_yaml(text: str, source: str) -> dict[str, Any]:
    """Parse YAML text into a mapping; duplicate keys and malformed YAML are errors."""
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ScenarioError(source, "", f"malformed YAML: {where}{problem}") from None
    if not isinstance(data, dict):
        raise ScenarioError(source, "", f"expected a mapping of keys (name, robot, start, goal, "
                            f"planner, ...), got {type(data).__name__}")
    return data


class _UniqueKeyLoader(yaml.SafeLoader):
    """Safe YAML loader that rejects duplicate keys."""


def _mapping(loader: yaml.SafeLoader, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
    seen: set[Any] = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark)
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping)


def _key_path(loc: Sequence[int | str], data: Any) -> str:
    """Key path like ``obstacles[1].radius`` from a pydantic ``loc`` (union tags dropped)."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
            data = data[part] if isinstance(data, list) and part < len(data) else None
            continue
        tags = (data.get("shape"), data.get("kind")) if isinstance(data, dict) else ()
        if isinstance(data, dict) and part not in data and part in tags:
            continue  # discriminated-union tag, not a key
        out += f".{part}" if out else part
        data = data.get(part) if isinstance(data, dict) else None
    return out


def _problem(error: Mapping[str, Any]) -> str:
    kind, msg = error["type"], str(error["msg"])
    if kind == "extra_forbidden":
        return "unknown key"
    if kind == "missing":
        return "required key missing"
    value = error.get("input")
    nan = isinstance(value, float) and math.isnan(value)
    if kind == "finite_number" or (nan and kind != "value_error"):  # not "should be <= 1"
        return f"expected a finite number, got {value!r}"
    msg = msg.removeprefix("Value error, ")
    msg = msg[:1].lower() + msg[1:]
    if kind.endswith("_type") or kind.endswith("_parsing"):
        msg += f", got {error['input']!r}"
    return msg


def validation_error(exc: ValidationError, data: Any, source: str,
                     prefix: str = "") -> ScenarioError:
    """One-line :class:`ScenarioError` from the first error of a pydantic ``ValidationError``."""
    error: dict[str, Any] = dict(exc.errors()[0])
    loc: list[int | str] = list(error["loc"])
    ctx: dict[str, Any] = dict(error.get("ctx") or {})
    key = ctx.get("key")
    if error["type"] in ("union_tag_invalid", "union_tag_not_found"):
        key = str(ctx.get("discriminator", "")).strip("'")
        error["msg"] = "required key missing"
        if error["type"] == "union_tag_invalid":
            error["msg"] = (f"unknown {key} {ctx.get('tag')!r}; "
                            f"choose one of {ctx.get('expected_tags')}")
    path = _key_path(loc, data)
    if key:
        path = f"{path}.{key}" if path and not str(key).startswith("[") else f"{path}{key}"
    if prefix:
        path = f"{prefix}.{path}" if path else prefix
    return ScenarioError(source, path, _problem(error))

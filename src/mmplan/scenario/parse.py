"""Reading scenario text and reporting its errors as one line each.

* :func:`read_text`: a scenario file's text, refused before reading when it is larger than
  :data:`MAX_FILE_BYTES` (10 MB);
* :func:`parse_yaml`: YAML text -> mapping (safe loader; duplicate keys and malformed YAML are
  errors with line and column). Hostile structure is refused before any object is built
  (:mod:`mmplan.scenario.safe_yaml`: deep nesting, alias bombs, recursive aliases, a sequence or
  mapping used as a mapping key), with the key path where it was found;
* :func:`validation_error`: the first error of a pydantic ``ValidationError`` -> a
  :class:`ScenarioError` whose message is ``<source>: <key path>: <problem>``, with the key
  path written ``obstacles[1].radius`` (list indices in brackets, union tags dropped);
  rejected values shown by :func:`~mmplan.scenario.safe_yaml.short_repr` (at most 200
  characters, never the full ``repr``: an aliased list of 10^9 numbers prints in microseconds).

Every message is one line of at most ``MAX_MESSAGE`` (500) characters.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from mmplan.errors import InputError
from mmplan.scenario.safe_yaml import MAX_MESSAGE, StructureError, clip, load, short_repr

#: Largest scenario file read (bytes); checked before reading.
MAX_FILE_BYTES = 10_000_000


def _short_source(source: str) -> str:
    """A long file name keeps its end (the part that names the file)."""
    return source if len(source) <= 160 else "..." + source[-157:]


class ScenarioError(InputError):
    """Invalid scenario (exit code 2); ``source`` is the file or built-in name.

    The message is one line of at most :data:`MAX_MESSAGE` characters whatever the input.
    """

    def __init__(self, source: str, field: str, problem: str) -> None:
        super().__init__(clip(field, 200), clip(problem, MAX_MESSAGE))
        self.source = source

    def __str__(self) -> str:
        inner = f"{self.field}: {self.problem}" if self.field else self.problem
        return clip(f"{_short_source(self.source)}: {inner}", MAX_MESSAGE)


def read_text(path: Path, source: str) -> str:
    """The UTF-8 text of a scenario file; files over :data:`MAX_FILE_BYTES` are not read.

    Raises:
        ScenarioError: unreadable, too large or not UTF-8.
    """
    limit = f"scenario files are limited to {MAX_FILE_BYTES / 1e6:g} MB"
    try:
        with path.open("rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if size > MAX_FILE_BYTES:
                raise ScenarioError(source, "", f"file is {size / 1e6:.1f} MB ({size} bytes); "
                                    f"{limit}")
            data = fh.read(MAX_FILE_BYTES + 1)  # a pipe or device reports no size
    except OSError as exc:
        raise ScenarioError(source, "", f"cannot read: {exc.strerror or exc}") from None
    if len(data) > MAX_FILE_BYTES:
        raise ScenarioError(source, "", f"more than {MAX_FILE_BYTES} bytes; {limit}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(source, "", f"not UTF-8 text (byte {exc.start}: "
                            f"{data[exc.start:exc.start + 1]!r})") from None


def parse_yaml(text: str, source: str) -> dict[str, Any]:
    """Parse YAML text into a mapping; duplicate keys and malformed YAML are errors.

    The structure is checked on the event stream before any object is built (nesting depth,
    values with aliases expanded, recursive aliases, collections as keys), so hostile text is
    refused in time proportional to its length and never expands in memory.
    """
    if len(text) > MAX_FILE_BYTES:
        raise ScenarioError(source, "", f"{len(text)} characters; scenario files are limited "
                            f"to {MAX_FILE_BYTES / 1e6:g} MB")
    try:
        data = load(text)
    except StructureError as exc:
        raise ScenarioError(source, exc.path, exc.problem) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        context = str(getattr(exc, "context", None) or "")
        if problem == "second occurrence" and context:  # "found duplicate anchor 'a'; first ..."
            problem = context.split(";")[0]
        raise ScenarioError(source, "", f"malformed YAML: {where}{problem}") from None
    except (ValueError, OverflowError, TypeError, RecursionError) as exc:  # e.g. int('9' * 5000)
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ScenarioError(source, "", f"malformed YAML: {first}") from None
    if not isinstance(data, dict):
        raise ScenarioError(source, "", f"expected a mapping of keys (name, robot, start, goal, "
                            f"planner, ...), got {type(data).__name__}")
    return data


def _key_path(loc: Sequence[int | str], data: Any) -> str:
    """Key path like ``obstacles[1].radius`` from a pydantic ``loc`` (union tags dropped)."""
    out = ""
    for part in loc:
        if isinstance(part, int) and not (isinstance(data, dict) and part in data):
            out += f"[{part}]"
            data = data[part] if isinstance(data, list) and part < len(data) else None
            continue
        tags = (data.get("shape"), data.get("kind")) if isinstance(data, dict) else ()
        if isinstance(data, dict) and part not in data and part in tags:
            continue  # discriminated-union tag, not a key
        name = str(part)
        if len(name) > 40 or not name.isprintable() or not name:
            name = short_repr(name, 40)  # a hostile key: quoted, cut, on one line
        out += f".{name}" if out else name
        data = data.get(part) if isinstance(data, dict) else None
    return out


def _problem(error: Mapping[str, Any]) -> str:
    kind, msg = error["type"], str(error["msg"])
    if kind == "extra_forbidden":
        return msg if msg.startswith("unknown key") else "unknown key"
    if kind == "missing":
        return "required key missing"
    value = error.get("input")
    nan = isinstance(value, float) and math.isnan(value)
    if kind == "finite_number" or (nan and kind != "value_error"):  # not "should be <= 1"
        return f"expected a finite number, got {short_repr(value)}"
    msg = msg.removeprefix("Value error, ")
    msg = re.sub(r" or instance of \w+", "", msg)  # pydantic names our class (a new user asked)
    msg = msg[:1].lower() + msg[1:]
    if kind.endswith("_type") or kind.endswith("_parsing"):
        msg += f", got {short_repr(error['input'])}"
    return msg


def _close_key(model: Any, loc: list[int | str]) -> str | None:
    """The key of ``model`` at ``loc``'s parent closest to its last part (difflib), None when
    none is close or the schema cannot say (a new-user trial: ``goal.positon: unknown key``
    named no alternative). Parts the schema does not know (a union's tag) are passed over."""
    import difflib

    try:
        schema = model.model_json_schema()
    except Exception:  # a schema pydantic cannot write: no suggestion
        return None
    defs = schema.get("$defs", {})

    def options(node: Any) -> list[dict[str, Any]]:
        out, todo = [], [node]
        while todo:
            item = todo.pop()
            if not isinstance(item, dict):
                continue
            if "$ref" in item:
                todo.append(defs.get(str(item["$ref"]).rsplit("/", 1)[-1]))
                continue
            for group in ("anyOf", "oneOf", "allOf"):
                todo.extend(item.get(group, []))
            out.append(item)
        return out

    nodes = options(schema)
    for part in loc[:-1]:
        below: list[dict[str, Any]] = []
        for node in nodes:
            if isinstance(part, int) and "items" in node:
                below += options(node["items"])
            elif isinstance(part, str) and part in node.get("properties", {}):
                below += options(node["properties"][part])
        nodes = below or nodes  # a union's tag: the same level
    keys = sorted({k for node in nodes for k in node.get("properties", {})})
    close = difflib.get_close_matches(str(loc[-1]), keys, n=1) if loc else []
    return close[0] if close else None


def validation_error(exc: ValidationError, data: Any, source: str,
                     prefix: str = "", model: Any = None) -> ScenarioError:
    """One-line :class:`ScenarioError` from the first error of a pydantic ``ValidationError``
    (``model``: the model validated, whose keys suggest a close one for an unknown key)."""
    error: dict[str, Any] = dict(exc.errors()[0])
    if error["type"] == "extra_forbidden" and model is not None:
        close = _close_key(model, list(error["loc"]))
        if close:
            error["msg"] = f"unknown key (did you mean {close}?)"
    loc: list[int | str] = list(error["loc"])
    ctx: dict[str, Any] = dict(error.get("ctx") or {})
    key = ctx.get("key")
    if error["type"] in ("union_tag_invalid", "union_tag_not_found"):
        key = str(ctx.get("discriminator", "")).strip("'")
        error["msg"] = "required key missing"
        if error["type"] == "union_tag_invalid":
            error["msg"] = (f"unknown {key} {short_repr(ctx.get('tag'), 80)}; "
                            f"choose one of {ctx.get('expected_tags')}")
    path = _key_path(loc, data)
    if key:
        path = f"{path}.{key}" if path and not str(key).startswith("[") else f"{path}{key}"
    if prefix:
        path = f"{prefix}.{path}" if path else prefix
    return ScenarioError(source, path, _problem(error))

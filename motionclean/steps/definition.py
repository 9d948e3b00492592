"""A pipeline's steps as written: the :class:`Step` record, made and validated from a
``[[step]]`` table of a pipeline file or an inline ``-f NAME:key=value,...`` step, and the
line and key a TOML error is on.

Everything is validated before any clip is read: an unknown filter, an unknown or missing
parameter, a wrong type or a value out of range raises :class:`UsageError` naming the step,
the key and what is allowed.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..core.errors import UsageError
from . import COMMON_PARAMS, REGISTRY, StepSpec
from .ranges import FrameRange

__all__ = ["Step", "make_step", "parse_inline", "parse_value"]


@dataclass(frozen=True)
class Step:
    """A validated pipeline step: the filter, its parameters, joints and positions flag."""

    spec: StepSpec
    params: dict
    joints: tuple[str, ...]
    positions: bool
    span: FrameRange | None = None

    def describe(self) -> dict:
        """The step as a plain dict (report and TOML form), defaults filled in."""
        out: dict[str, Any] = {"filter": self.spec.name}
        names = self.spec.relevant(self.params) if self.spec.relevant else tuple(self.params)
        out.update({k: v for k, v in self.params.items() if v is not None and k in names})
        if self.spec.run_motion is None:  # a whole-clip step takes every joint
            out["joints"] = list(self.joints)
            out["positions"] = self.positions
        if self.span is not None:
            out.update(self.span.describe())
        return out


def table_of(step: Step) -> dict:
    """A step as the table :func:`make_step` validates: its filter, the parameters given
    (None: the default), joints, positions and frame range."""
    table: dict[str, Any] = {"filter": step.spec.name}
    if not isinstance(step.params, dict):
        raise TypeError(f"params: expected a dict, got {type(step.params).__name__}")
    params = step.params
    defaults = {param.name: param.default for param in step.spec.params}
    full = defaults | params
    names = step.spec.relevant(full) if step.spec.relevant else tuple(full)
    table.update(  # (a default another setting makes irrelevant, as a validated step has)
        {
            k: v
            for k, v in params.items()
            if v is not None and (k in names or k not in defaults or v != defaults[k])
        }
    )
    if step.spec.run_motion is None:
        joints = step.joints
        if not isinstance(joints, str | list | tuple):
            raise TypeError(f"joints: expected names or patterns, got {type(joints).__name__}")
        table["joints"] = joints if isinstance(joints, str) else list(joints)
        table["positions"] = step.positions
    if step.span is not None:
        table.update(step.span.describe())
    return table


def make_step(table: dict, where: str, key_places: dict[str, str] | None = None) -> Step:
    """Validate one step table (``{"filter": ..., params...}``) into a :class:`Step`.
    ``where`` starts its errors; ``key_places`` gives a key's own (its line in a file),
    used for an error about that key."""
    if not isinstance(table, dict):
        raise UsageError(f"{where}: a step must be a table of key = value pairs")
    table = _given(table)
    name = table.pop("filter", None)
    if name is None:
        raise UsageError(f"{where}: missing 'filter'; one of {', '.join(REGISTRY)}")
    spec = REGISTRY.get(name)
    if spec is None:
        raise UsageError(f"{where}: unknown filter {name!r}; one of {', '.join(REGISTRY)}")
    places = {key: f"{place} ({name})" for key, place in (key_places or {}).items()}
    where = f"{where} ({name})"
    allowed = spec.params + COMMON_PARAMS
    # (a whole-clip step refuses joints and ranges in a line of its own: not listed as allowed)
    listed = spec.params if spec.run_motion is not None else allowed
    params: dict[str, Any] = {}
    for key, value in table.items():
        param = next((p for p in allowed if p.name == key), None)
        if param is None:
            raise UsageError(
                f"{places.get(key, where)}: unknown parameter {key!r}; allowed: "
                + ", ".join(p.name for p in listed)
            )
        params[key] = param.coerce(value, places.get(key, where))
    for param in spec.params:
        params.setdefault(param.name, param.default)
    joints = tuple(params.pop("joints", ["*"]))
    positions = params.pop("positions", spec.positions_default)
    # (a range's errors name its key's line in a file: the first of frames, seconds given)
    ranged = places.get(next((k for k in ("frames", "seconds") if k in table), ""), where)
    span = FrameRange.from_params(
        params.pop("frames", None), params.pop("seconds", None), params.pop("blend", 5), ranged
    )
    if span is None and "blend" in table:
        raise UsageError(
            f"{places.get('blend', where)}: blend is used only with frames or seconds (a range)"
        )
    if span is not None and spec.run_motion is not None:
        raise UsageError(f"{ranged}: this step changes the whole clip; it takes no frame range")
    given = [key for key in ("joints", "positions") if key in table]
    if spec.run_motion is not None and given:
        raise UsageError(
            f"{places.get(given[0], where)}: this step changes the whole clip; it takes no "
            "joints or positions"
        )
    if spec.resolve is not None:
        spec.resolve(params, lambda *keys: next((places[k] for k in keys if k in places), where))
    if spec.relevant is not None:
        used = spec.relevant(params)
        common = {p.name for p in COMMON_PARAMS}
        unused = [key for key in table if key not in used and key not in common]
        if unused:
            raise UsageError(
                f"{places.get(unused[0], where)}: {unused[0]!r} is not used with "
                + ", ".join(f"{k}={params[k]}" for k in used if isinstance(params[k], str))
                + f"; it takes {', '.join(k for k in used if not isinstance(params[k], str))}"
            )
    return Step(spec, params, joints, positions, span)


def _given(table: dict) -> dict:
    """A copy of a step ``table`` as given: a report's entry (its ``pipeline``, which adds
    the frames a ranged step ``touched`` and the ``frames`` a ``seconds`` range became)
    without what the report added, so it reads back as the same step."""
    table = dict(table)
    if "touched" in table:
        del table["touched"]
        if "seconds" in table:
            table.pop("frames", None)
    return table


def parse_value(text: str) -> Any:
    """An inline value read as TOML (numbers, booleans, lists); bare words are strings."""
    text = text.strip()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        pass
    if text.startswith("[") and text.endswith("]"):
        return [parse_value(item) for item in _split_top(text[1:-1]) if item.strip()]
    return text


def _split_top(text: str) -> list[str]:
    """Split on commas outside brackets and quotes."""
    parts, depth, quote, start = [], 0, None, 0
    for i, ch in enumerate(text):
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def parse_inline(text: str) -> dict:
    """``"bilateral:sigma_t=1,sigma_g=0.1"`` -> ``{"filter": "bilateral", ...}``."""
    name, _, rest = text.partition(":")
    table: dict[str, Any] = {"filter": name.strip()}
    for item in _split_top(rest) if rest.strip() else []:
        key, eq, value = item.partition("=")
        if not eq or not key.strip():
            raise UsageError(f"-f {text!r}: expected key=value, got {item.strip()!r}")
        if key.strip() in table:
            raise UsageError(f"-f {text!r}: {key.strip()!r} is given twice")
        try:
            table[key.strip()] = parse_value(value)
        except RecursionError:
            raise UsageError(f"-f {_brief(text)}: {key.strip()}: nested too deeply") from None
        except ValueError:  # an integer of more digits than Python converts
            raise UsageError(
                f"-f {_brief(text)}: {key.strip()}: a number with too many digits (out of range)"
            ) from None
    return table


def _brief(text: str, most: int = 60) -> str:
    """``text`` quoted for an error line, its middle cut when it is long."""
    return repr(text) if len(text) <= most else repr(text[: most - 20] + "..." + text[-15:])


#: A ``[[step]]`` table's header line in a pipeline file.
STEP_HEADER = re.compile(r"\s*\[\[\s*step\s*\]\]\s*(#.*)?$")


#: Any table header line (``[name]``, ``[[name]]``).
TABLE_HEADER = re.compile(r"\s*\[")


#: Where tomllib says a syntax error is: ``... (at line L, column C)``.
TOML_PLACE = re.compile(r"^(.*) \(at line (\d+), column (\d+)\)$", re.DOTALL)


#: A ``key = value`` line of a step table: its key, bare or quoted (not dotted).
TOML_KEY = re.compile(r"""\s*([A-Za-z0-9_-]+|"[^"\\]*"|'[^']*')\s*=""")


#: What tomllib says of a key given twice in one table.
TOML_TWICE = "Cannot overwrite a value"


def toml_error(path: Path, message: str, text: str) -> str:
    """A TOML syntax error of file ``text`` as ``FILE:LINE: invalid TOML: what``; a key
    given twice in a ``[[step]]`` table as ``FILE:LINE: step N (filter): 'key' is given
    twice ...``, as an inline step's is."""
    place = TOML_PLACE.match(message)
    if place is not None:
        what, line, column = place.groups()
        if what == TOML_TWICE:
            twice = _key_given_twice(text.splitlines(), int(line))
            if twice is not None:
                return f"{path}:{twice}"
        return f"{path}:{line}: invalid TOML: {what} (column {column})"
    if message.endswith(" (at end of document)"):
        what = message.removesuffix(" (at end of document)")
        return f"{path}:{len(text.splitlines()) or 1}: invalid TOML: {what} (at the end)"
    return f"{path}: invalid TOML: {message}"


def _key_given_twice(lines: list[str], line: int) -> str | None:
    """``LINE: step N (filter): 'key' is given twice ...`` for the key tomllib refused to
    overwrite at ``line`` (1-based; the end of the value, which may span lines), found as
    the last ``key =`` line up to it whose key an earlier line of the same ``[[step]]``
    table gave; None when the line is in no step table or no such key is found (a dotted
    key, a table given twice: tomllib's own message is said)."""
    headers = [i for i, text in enumerate(lines[:line]) if STEP_HEADER.match(text)]
    if not headers:
        return None
    table = lines[headers[-1] + 1 : line]
    if any(TABLE_HEADER.match(text) for text in table):
        return None  # in another table after the step's
    keys = [(i, _toml_key(text)) for i, text in enumerate(table)]
    given = [(i, key) for i, key in keys if key is not None]
    if not given:
        return None
    last, key = given[-1]
    first = next((i for i, k in given[:-1] if k == key), None)
    if first is None:
        return None
    start = headers[-1] + 2  # the table's first line after its header, 1-based
    name = next(
        (_toml_string(text) for i, text in enumerate(table) if keys[i][1] == "filter"), None
    )
    step = f"step {len(headers)}" + (f" ({name})" if name else "")
    return (
        f"{start + last}: {step}: {key!r} is given twice (first on line {start + first}); "
        "each key once"
    )


def key_lines(rows: list[str], headers: list[int]) -> list[dict[str, int]]:
    """Each ``[[step]]`` table's ``key = value`` lines (1-based), by key: the rows after
    its header line (``headers``, 1-based) up to the next table header."""
    out = []
    for header in headers:
        keys: dict[str, int] = {}
        for line in range(header + 1, len(rows) + 1):
            if TABLE_HEADER.match(rows[line - 1]):
                break
            key = _toml_key(rows[line - 1])
            if key is not None:
                keys.setdefault(key, line)
        out.append(keys)
    return out


def _toml_key(text: str) -> str | None:
    """The key of a ``key = value`` line (quotes taken off), None for any other line."""
    found = TOML_KEY.match(text)
    if found is None:
        return None
    key = found.group(1)
    return key[1:-1] if key[0] in "\"'" else key


def _toml_string(text: str) -> str | None:
    """The string value of a ``key = "value"`` line, None when it is not one."""
    try:
        value = tomllib.loads(text).popitem()[1]
    except (tomllib.TOMLDecodeError, KeyError):
        return None
    return value if isinstance(value, str) else None

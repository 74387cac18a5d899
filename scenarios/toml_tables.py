"""TOML tables into validated frozen dataclasses, and TOML files by path or built-in name.

Shared by the scenario, cohort, room and benchmark files: unknown keys are rejected with a message
naming the key, its table and the keys allowed there; every value is checked against its type hint.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import tomllib
import types
import typing
from pathlib import Path
from typing import Any

from fusion.errors import ScenarioError


def _strip_optional(tp: Any) -> tuple[Any, bool]:
    if isinstance(tp, types.UnionType) or typing.get_origin(tp) is typing.Union:
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return args[0], True
    return tp, False


def _convert(value: Any, tp: Any, where: str) -> Any:
    tp, optional = _strip_optional(tp)
    if value is None and optional:
        return None
    origin = typing.get_origin(tp)
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        try:
            return tp(value)
        except ValueError:
            raise ScenarioError(f"{where}: {value!r} is not one of {[m.value for m in tp]}") from None
    if origin is list:
        (item_tp,) = typing.get_args(tp)
        if not isinstance(value, list):
            raise ScenarioError(f"{where}: expected a list, got {value!r}")
        return [_convert(v, item_tp, f"{where}[{i}]") for i, v in enumerate(value)]
    if origin is dict:
        key_tp, item_tp = typing.get_args(tp)
        if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
            raise ScenarioError(f"{where}: expected a table, got {value!r}")
        return {k: _convert(v, item_tp, f"{where}.{k}") for k, v in value.items()}
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ScenarioError(f"{where}: expected a number, got {value!r}")
        if not math.isfinite(value):
            raise ScenarioError(f"{where}: expected a finite number, got {value!r}")
        return float(value)
    if tp in (int, str, bool):
        if not isinstance(value, tp) or (tp is int and isinstance(value, bool)):
            raise ScenarioError(f"{where}: expected {tp.__name__}, got {value!r}")
        return value
    if dataclasses.is_dataclass(tp):
        return build_table(tp, value, where)
    raise ScenarioError(f"{where}: unsupported value {value!r}")


def build_table(cls: type, table: Any, where: str) -> Any:
    """An instance of the dataclass ``cls`` from a TOML table, each value checked against its type hint.

    ``where`` names the table in error messages. Unknown keys and wrongly typed values raise
    :class:`ScenarioError` listing what is allowed.
    """
    if not isinstance(table, dict):
        raise ScenarioError(f"{where}: expected a table, got {table!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = [k for k in table if k not in fields]
    if unknown:
        raise ScenarioError(f"unknown key {unknown[0]!r} in [{where}]; allowed keys: {', '.join(fields)}")
    kwargs = {}
    for name, value in table.items():
        kwargs[name] = _convert(value, hints[name], f"{where}.{name}")
    missing = [n for n, f in fields.items() if n not in kwargs and f.default is dataclasses.MISSING
               and f.default_factory is dataclasses.MISSING]
    if missing:
        raise ScenarioError(f"[{where}] is missing required key(s): {', '.join(missing)}")
    return cls(**kwargs)


def resolve_builtin(name_or_path: str | Path, directory: Path, kind: str) -> Path:
    """A TOML file by path, or by the name of a built-in file in ``directory`` (without suffix)."""
    p = Path(name_or_path)
    if p.is_file():
        return p
    builtin = directory / f"{p.stem}.toml"
    known = (Path("."), Path(directory.name), Path("scenarios"), Path("scenarios") / directory.name)
    if p.suffix in ("", ".toml") and builtin.is_file() and p.parent in known:
        return builtin
    names = sorted(f.stem for f in directory.glob("*.toml"))
    raise ScenarioError(f"{kind} {str(name_or_path)!r} not found; give a TOML path or a built-in: {', '.join(names)}")


def read_toml(path: Path) -> dict[str, Any]:
    """The parsed TOML document at ``path``; invalid TOML is a :class:`ScenarioError` naming the file."""
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read the file ({exc.strerror or exc})") from None


def without_none(value: Any) -> Any:
    """``value`` with every None entry of its dicts left out, recursively (TOML has no null)."""
    if isinstance(value, dict):
        return {k: without_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, list):
        return [without_none(v) for v in value]
    return value

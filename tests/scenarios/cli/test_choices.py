"""Option choices: taken from the library's Enums, loaded only when needed, defaults among them."""

from __future__ import annotations

import enum
import subprocess
import sys

import pytest

from scenarios.cli import commands
from scenarios.cli.choices import LazyChoices


def test_building_the_parser_imports_no_library():
    code = ("import sys; from scenarios.cli import build_parser; build_parser(); "
            "print(','.join(m for m in ('numpy', 'scipy', 'mujoco', 'open3d', 'sim', 'fusion.merge') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""


def test_every_choice_list_is_lazy_non_empty_and_holds_its_default():
    checked = 0
    for name, parser in commands().items():
        for action in parser._actions:
            if action.choices is None:
                continue
            assert isinstance(action.choices, LazyChoices), f"{name} {action.dest}: choices typed by hand"
            values = list(action.choices)
            assert values and all(isinstance(v, str) for v in values)
            defaults = action.default if isinstance(action.default, (list, LazyChoices)) else [action.default]
            assert all(d is None or d in action.choices for d in defaults), f"{name} {action.dest}: {action.default}"
            checked += 1
    assert checked >= 25


def test_lazy_choices_follow_the_enum():
    class Colour(enum.Enum):
        RED = "red"
        GREEN = "green"
        BLUE = "blue"

    module = type(sys)("colour_module")
    module.Colour = Colour
    module.NAMES = {"a": 1, "b": 2}
    sys.modules["colour_module"] = module
    try:
        assert list(LazyChoices("colour_module.Colour")) == ["red", "green", "blue"]
        assert list(LazyChoices("colour_module.Colour", "BLUE", "RED")) == ["blue", "red"]
        assert "green" not in LazyChoices("colour_module.Colour", "RED") and len(LazyChoices("colour_module.NAMES")) == 2
    finally:
        del sys.modules["colour_module"]


def test_help_lists_the_choices_and_a_bad_value_names_them(capsys):
    parser = commands()["fuse"]
    assert "one of merge, kinematic" in " ".join(parser.format_help().split())
    with pytest.raises(SystemExit):
        parser.parse_args(["run", "--calib", "c", "--out", "o", "--fit", "bogus"])
    assert "invalid choice: 'bogus'" in capsys.readouterr().err


def test_export_units_are_the_exports_units():
    from fusion.io.export import EXPORT_UNITS

    units = next(a for a in commands()["export"]._actions if a.dest == "units")
    assert list(units.choices) == [u.value for u in EXPORT_UNITS]

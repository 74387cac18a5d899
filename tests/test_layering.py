"""The dependency rules of the code map (README): fusion/ and fma/ never import sim/ or mujoco (they
have to work on real recordings); inside fusion/ the stages import one way, io <- calibrate <- merge
<- live, and the data model at the top of fusion/ imports no stage; no module imports another's
private names."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = {"sim", "mujoco", "scenarios"}


STAGES = ("io", "calibrate", "merge", "live")  # each may import only the ones before it
PROJECT = ("fusion", "fma", "sim", "scenarios")


def _imported_modules(path: Path) -> set[str]:
    """Full dotted names of the modules ``path`` imports (statically or through import_module)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) in (
            "import_module",
            "__import__",
        ):
            for arg in node.args[:1]:
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    names.add(arg.value)
    return names


def _imported_top_modules(path: Path) -> set[str]:
    return {name.split(".")[0] for name in _imported_modules(path)}


def _stage(module: str) -> int | None:
    """Index of the fusion stage a dotted module name belongs to; -1 for the data model; None outside."""
    parts = module.split(".")
    if parts[0] != "fusion":
        return None
    return STAGES.index(parts[1]) if len(parts) > 1 and parts[1] in STAGES else -1


@pytest.mark.parametrize("package", ["fusion", "fma"])
def test_package_does_not_import_sim_or_mujoco(package):
    files = sorted((ROOT / package).rglob("*.py"))
    assert files, f"no sources found in {package}/"
    offenders = {str(f.relative_to(ROOT)): sorted(_imported_top_modules(f) & FORBIDDEN) for f in files}
    assert not {k: v for k, v in offenders.items() if v}


def test_scan_detects_a_forbidden_import(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import numpy\nfrom sim.humanoid import x\nimport importlib\nimportlib.import_module('mujoco')\n")
    assert _imported_top_modules(bad) & FORBIDDEN == {"sim", "mujoco"}


def test_fusion_stages_import_one_way():
    offenders = []
    for f in sorted((ROOT / "fusion").rglob("*.py")):
        own = _stage(".".join(f.relative_to(ROOT).with_suffix("").parts))
        for name in _imported_modules(f):
            other = _stage(name)
            if other is not None and other > own:
                offenders.append(f"{f.relative_to(ROOT)} imports {name}")
    assert not offenders


def test_no_module_imports_private_names_of_another():
    offenders = []
    for package in PROJECT + ("tests",):
        for f in sorted((ROOT / package).rglob("*.py")):
            tree = ast.parse(f.read_text(encoding="utf-8"))
            for node in ast.walk(tree):
                if (isinstance(node, ast.ImportFrom) and node.level == 0 and node.module
                        and node.module.split(".")[0] in PROJECT + ("tests",)):
                    offenders += [f"{f.relative_to(ROOT)}: {node.module}.{a.name}" for a in node.names
                                  if a.name.startswith("_")]
    assert not offenders


def test_stage_rule_detects_an_upward_import():
    assert _stage("fusion.io.recording") < _stage("fusion.merge.methods")
    assert _stage("fusion.topology") == -1 and _stage("numpy") is None

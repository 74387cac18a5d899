"""The dependency rules of the code map (README): fusion/ and fma/ never import sim/ or mujoco (they
have to work on real recordings); inside fusion/ the stages import one way, io <- calibrate <- merge
<- live, and the data model at the top of fusion/ imports no stage; inside scenarios/ the core imports
no sub-package, a workflow sub-package only the core, the benchmarks any workflow, and nothing but the
CLI imports the CLI; no import cycle anywhere; no module imports another's private names; every
package says what it holds; no module is longer than 400 lines."""

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
            names |= {f"{node.module}.{a.name}" for a in node.names}  # a sub-module imported by name
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
    assert _stage("fusion.io.recording_files") < _stage("fusion.merge.methods")
    assert _stage("fusion.topology") == -1 and _stage("numpy") is None


def _modules() -> dict[str, Path]:
    """Dotted name -> file of every module of the project's packages."""
    out = {}
    for package in PROJECT:
        for f in sorted((ROOT / package).rglob("*.py")):
            parts = f.relative_to(ROOT).with_suffix("").parts
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = f
    return out


def _import_graph() -> dict[str, set[str]]:
    """Module -> the project modules it imports (a name imported from a package counts as that
    package unless it is a sub-module); a module's own packages are left out."""
    mods = _modules()

    def owner(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    graph = {}
    for m, f in mods.items():
        deps = {o for o in map(owner, _imported_modules(f)) if o is not None}
        graph[m] = {d for d in deps if d != m and not m.startswith(d + ".")}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter[0]
        counter[0] += 1
        stack.append(start)
        on.add(start)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    out.append(sorted(component))
    return out


def test_no_import_cycle_anywhere():
    assert not _cycles(_import_graph())


def test_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def _scenarios_part(module: str) -> str | None:
    """``core`` for a module at the top of scenarios/, its sub-package's name otherwise."""
    parts = module.split(".")
    if parts[0] != "scenarios" or len(parts) == 1:
        return None
    is_package = (ROOT / Path(*parts) / "__init__.py").is_file()
    return parts[1] if len(parts) > 2 or is_package else "core"


def test_scenarios_core_workflows_benchmarks_and_cli_import_one_way():
    offenders = []
    for m, deps in _import_graph().items():
        own = _scenarios_part(m)
        if own is None or own == "cli":
            continue
        for d in deps:
            other = _scenarios_part(d)
            if other is None or other == own:
                continue
            allowed = other == "core" or (own == "bench" and other != "cli")
            if not allowed:
                offenders.append(f"{m} imports {d}")
    assert not offenders


def test_every_package_says_what_it_holds():
    missing = []
    for package in PROJECT:
        for d in [ROOT / package, *sorted(p for p in (ROOT / package).rglob("*") if p.is_dir())]:
            if "__pycache__" in d.parts or not any(d.glob("*.py")):
                continue
            init = d / "__init__.py"
            if not init.is_file() or not ast.get_docstring(ast.parse(init.read_text(encoding="utf-8"))):
                missing.append(str(d.relative_to(ROOT)))
    assert not missing


def test_no_module_is_longer_than_400_lines():
    long = {str(f.relative_to(ROOT)): n for f in _modules().values()
            if (n := len(f.read_text(encoding="utf-8").splitlines())) > 400}
    assert not long



def test_scenarios_keeps_a_small_core():
    core = sorted(p.name for p in (ROOT / "scenarios").glob("*.py"))
    assert len(core) <= 12, f"scenarios/ has {len(core)} top-level modules; a workflow belongs in a sub-package: {core}"

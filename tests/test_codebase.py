"""The codebase's shape: no import cycles, modules of a readable size."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# package -> folder: the repository's controllers/ installs as twolink.controllers
PACKAGES = {"twolink": "twolink", "twolink.controllers": "controllers"}
MAX_LINES = 700  # one concept, one home: a module past this holds more than one


def module_files() -> dict[str, Path]:
    """Dotted module name -> file, for every module of the project's packages."""
    out = {}
    for package, folder in PACKAGES.items():
        for path in sorted((REPO / folder).rglob("*.py")):
            parts = list(path.relative_to(REPO / folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join([package, *parts])] = path
    return out


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The project modules that ``name`` imports anywhere in its file (also inside
    functions: a deferred import still closes a cycle), each resolved to the most
    specific module: ``from a.b import c`` is ``a.b.c`` where that is a module."""
    is_package = path.name == "__init__.py"
    found = set()
    for node in _executed_nodes(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative import
                anchor = name.split(".")
                anchor = anchor if is_package else anchor[:-1]
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            targets = [f"{base}.{alias.name}" for alias in node.names]
            targets = [t if t in modules else base for t in targets]
        else:
            continue
        for target in targets:
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def _executed_nodes(tree: ast.AST):
    """Every node, except what sits under ``if TYPE_CHECKING:`` (never imported at run
    time, so it closes no cycle)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                stack.extend(child.orelse)
            else:
                stack.append(child)


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_cycle_finder_finds_a_cycle_through_a_deferred_import(tmp_path):
    modules = {"pkg.a": tmp_path / "a.py", "pkg.b": tmp_path / "b.py", "pkg.c": tmp_path / "c.py"}
    modules["pkg.a"].write_text("from pkg.b import thing\n")
    modules["pkg.b"].write_text("def f():\n    from pkg import a\n")
    modules["pkg.c"].write_text("import pkg.a\nif TYPE_CHECKING:\n    import pkg.b\n")
    graph = {m: imports_of(m, p, modules) for m, p in modules.items()}
    assert graph == {"pkg.a": {"pkg.b"}, "pkg.b": {"pkg.a"}, "pkg.c": {"pkg.a"}}
    assert cycles(graph) == [["pkg.a", "pkg.b"]]


def test_no_import_cycle_among_the_project_modules():
    modules = module_files()
    graph = {m: imports_of(m, p, modules) for m, p in modules.items()}
    assert graph["twolink.simulation.experiment"] >= {
        "twolink.simulation.config",
        "twolink.arm.plant",
    }  # sanity
    assert cycles(graph) == []


# The layers, from the ground up; a module may import its own layer and those below.
LAYERS = {
    "twolink.foundation": 0,  # imports nothing of twolink outside itself
    "twolink.arm": 1,
    "twolink.controllers": 1,
    "twolink.simulation": 2,
    "twolink.figures": 3,
    "twolink.tracing": 3,
    "twolink.sweep": 4,
    "twolink.studies": 4,
    "twolink.interface": 5,  # the command line
    "twolink.api": 5,
    "twolink.__main__": 5,
    "twolink": 5,  # the public names, loaded on first use
}


def layer_of(module: str) -> int:
    while module not in LAYERS:
        module = module.rpartition(".")[0]
    return LAYERS[module]


def layer_violations(graph: dict[str, set[str]]) -> list[str]:
    return sorted(
        f"{m} (layer {layer_of(m)}) imports {t} (layer {layer_of(t)})"
        for m, targets in graph.items()
        for t in targets
        if layer_of(t) > layer_of(m)
    )


def test_the_layer_check_finds_an_upward_import(tmp_path):
    modules = {
        "twolink.foundation.io": tmp_path / "io.py",
        "twolink.simulation.sim": tmp_path / "sim.py",
        "twolink.figures.plots": tmp_path / "plots.py",
    }
    modules["twolink.foundation.io"].write_text("x = 1\n")
    modules["twolink.simulation.sim"].write_text(
        "from twolink.foundation.io import x\ndef f():\n    from twolink.figures import plots\n"
    )
    modules["twolink.figures.plots"].write_text("from twolink.simulation.sim import f\n")
    graph = {m: imports_of(m, p, modules) for m, p in modules.items()}
    assert layer_violations(graph) == [
        "twolink.simulation.sim (layer 2) imports twolink.figures.plots (layer 3)"
    ]


def test_no_module_imports_a_layer_above_its_own():
    modules = module_files()
    assert all(layer_of(m) >= 0 for m in modules)  # every module has a layer
    graph = {m: imports_of(m, p, modules) for m, p in modules.items()}
    outside = {
        m: {t for t in graph[m] if not t.startswith("twolink.foundation")}
        for m in modules
        if m.startswith("twolink.foundation")
    }
    assert not any(outside.values()), outside  # the foundation imports nothing else
    assert layer_violations(graph) == []


@pytest.mark.parametrize("name", sorted(module_files()))
def test_modules_stay_readable(name):
    lines = module_files()[name].read_text().count("\n")
    assert lines <= MAX_LINES, f"{name} has {lines} lines: split it by concern"


def test_the_controllers_install_as_twolink_controllers_not_a_top_level_module(tmp_path):
    """No generic ``controllers`` module in site-packages: outside the checkout it does not
    import, ``twolink.controllers`` does, and the package list maps the folder there."""
    import subprocess
    import sys
    import tomllib

    code = (
        "import importlib.util as u\n"
        "assert u.find_spec('controllers') is None, u.find_spec('controllers')\n"
        "from twolink.controllers import ComputedTorque, FuzzyComputedTorque\n"
        "from twolink import ComputedTorque as C\n"
        "assert C is ComputedTorque\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    setuptools = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert all(p == "twolink" or p.startswith("twolink.") for p in setuptools["packages"])
    assert setuptools["package-dir"] == {
        "twolink.controllers": "controllers",
        "twolink.runs": "runs",  # shipped files: package data (tests/test_wheel.py)
        "twolink.models": "models",
    }


def test_the_old_module_names_import_the_modules_they_became():
    # DESIGN.md's contract names (twolink.params, twolink.dynamics, twolink.plant,
    # twolink.metrics), the flat studies (twolink.studies.claims) and the .fis modules
    # (twolink.controllers.fuzzy.matlab): the same module object, its own spec
    import importlib
    import pickle

    import twolink
    from twolink import aliases

    assert "twolink.studies.claims" in aliases.ALIASES
    assert aliases.ALIASES["twolink.params"] == "twolink.arm.params"
    assert "twolink.reproduce" not in aliases.ALIASES  # a public function's name
    for old, new in aliases.ALIASES.items():
        module = importlib.import_module(old)
        assert module is importlib.import_module(new), old
        assert module.__name__ == module.__spec__.name == new
        assert importlib.util.find_spec(new) is not None  # no alias of a missing module
    from twolink.dynamics import mass_matrix
    from twolink.params import ArmParams

    assert mass_matrix(ArmParams(), [0.1, 0.2]).shape == (2, 2)
    assert pickle.loads(pickle.dumps(ArmParams(m1=2.0))) == ArmParams(m1=2.0)
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("twolink.no_such_module")
    from twolink.studies.reproduction.reproduce import reproduce

    assert twolink.reproduce is reproduce  # not shadowed by a module of that name


MAX_MODULES_PER_FOLDER = 15  # a reader takes in a folder's names at a glance


def test_no_folder_holds_more_than_15_modules_directly():
    folders: dict[Path, int] = {}
    for path in module_files().values():
        if path.name != "__init__.py":
            folders[path.parent] = folders.get(path.parent, 0) + 1
    crowded = {str(f.relative_to(REPO)): n for f, n in folders.items() if n > 15}
    assert not crowded, crowded


def test_every_stage_of_the_studies_is_a_package_with_a_one_line_docstring():
    import ast as _ast

    studies = REPO / "twolink" / "studies"
    stages = sorted(p for p in studies.iterdir() if (p / "__init__.py").exists())
    assert [p.name for p in stages] == ["designs", "judgments", "reproduction"]
    assert not [p.name for p in studies.glob("*.py") if p.name != "__init__.py"]
    for stage in stages:
        doc = _ast.get_docstring(_ast.parse((stage / "__init__.py").read_text()))
        assert doc and "\n" not in doc.strip(), stage


MAX_LONG_FUNCTIONS = 12  # functions past a screen (80 lines); each split where its steps have names


def test_at_most_12_functions_are_longer_than_a_screen():
    long = sorted(
        (node.end_lineno - node.lineno + 1, f"{name}.{node.name}")
        for name, path in module_files().items()
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.end_lineno - node.lineno + 1 > 80
    )
    assert len(long) <= MAX_LONG_FUNCTIONS, long

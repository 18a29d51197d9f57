"""The package's import graph stays one-way (issue 15): read with ast, imports inside
functions and under ``TYPE_CHECKING`` included.

- no import cycles;
- no upward imports: layers run base (errors, version, files) -> spline -> estimator / aero
  -> sim -> cli -> launcher, and only the CLI may import the package face ``simplexspline``;
- no private name (leading underscore) taken from another sub-package (a sub-package is the
  unit of privacy: its modules may share private helpers);
- an import of a project module inside a function says why, in a comment on its line or the
  line above (optional dependencies and lazy heavy imports are the only reasons);
- no working module re-exports names it imports ("re-exported" shims); moved public paths
  are small deprecation modules instead.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "simplexspline"

#: Layer of each top-level part; a module may import only modules of its layer or below.
LAYERS = {
    "errors": 0, "_version": 0, "_files": 0, "_deprecation": 0, "_workers": 0,
    "_compute_slots": 0, "_golden_section": 0,
    "distributed": 1,  # the deprecation module of simplexspline.spline.distributed
    "spline": 1,
    "estimator": 2, "aero": 2,
    "sim": 3,
    "": 4,          # the package face simplexspline/__init__.py
    "cli": 5,
    "launcher": 6, "__main__": 6,   # the command's entry point, over the CLI
}
#: Deprecation modules at old import paths: they forward names, they hold no code.
SHIMS = {
    "simplexspline.distributed", "simplexspline.spline.export", "simplexspline.spline.coverage",
    "simplexspline.spline.statistics", "simplexspline.spline.penalty",
    "simplexspline.spline.triangulation", "simplexspline.spline.io",
    "simplexspline.aero.structure", "simplexspline.aero.model", "simplexspline.aero.flightdata",
    "simplexspline.aero.validation", "simplexspline.aero.coefficients",
    "simplexspline.aero.tables",
}


def _modules() -> dict[str, Path]:
    mods = {}
    for f in (SRC / PACKAGE).rglob("*.py"):
        parts = list(f.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        mods[".".join(parts)] = f
    return mods


MODULES = _modules()


def _layer(module: str) -> int:
    parts = module.split(".")
    return LAYERS[parts[1] if len(parts) > 1 else ""]


def _is_package(module: str) -> bool:
    return MODULES[module].name == "__init__.py"


class _Imports(ast.NodeVisitor):
    """Every import of one module: (target module, imported name or None, line, in a function)."""

    def __init__(self, module: str):
        self.module, self.depth, self.found = module, 0, []
        self.package = module if _is_package(module) else module.rpartition(".")[0]

    def visit_FunctionDef(self, node):
        self.depth += 1
        self.generic_visit(node)
        self.depth -= 1

    visit_AsyncFunctionDef = visit_FunctionDef

    def visit_Import(self, node):
        for a in node.names:
            if a.name in MODULES:
                self.found.append((a.name, None, node.lineno, self.depth > 0))

    def visit_ImportFrom(self, node):
        base = node.module or ""
        if node.level:
            up = self.package.split(".")[: len(self.package.split(".")) - node.level + 1]
            base = ".".join(up + ([base] if base else []))
        for a in node.names:
            sub = f"{base}.{a.name}"
            if sub in MODULES:
                self.found.append((sub, None, node.lineno, self.depth > 0))
            elif base in MODULES:
                self.found.append((base, a.name, node.lineno, self.depth > 0))


def _imports() -> dict[str, list]:
    out = {}
    for name, path in MODULES.items():
        v = _Imports(name)
        v.visit(ast.parse(path.read_text(), filename=str(path)))
        out[name] = [i for i in v.found if i[0] != name]
    return out


IMPORTS = _imports()


def _cycles() -> list[list[str]]:
    edges = defaultdict(set)
    for m, found in IMPORTS.items():
        for target, _, _, _ in found:
            if not target.startswith(m + "."):       # a package re-exporting its children
                edges[m].add(target)
    index, low, stack, on, comps = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    for v in sorted(MODULES):
        if v not in index:
            visit(v)
    return comps


def test_the_graph_is_read():
    assert len(MODULES) > 60
    targets = {t for t, _, _, _ in IMPORTS["simplexspline.spline.space"]}
    assert "simplexspline.spline.bform" in targets


def test_no_import_cycles():
    assert _cycles() == []


def test_no_upward_imports():
    upward = [f"{m}:{line} imports {t}" for m, found in IMPORTS.items()
              for t, _, line, _ in found if _layer(t) > _layer(m)]
    assert upward == []


def _package(module: str) -> str:
    return module if _is_package(module) else module.rpartition(".")[0]


def test_no_private_names_across_sub_packages():
    private = [f"{m}:{line} takes {t}.{n}" for m, found in IMPORTS.items()
               for t, n, line, _ in found
               if n is not None and n.startswith("_") and not n.startswith("__")
               and _package(t) != _package(m)]
    assert private == []


def test_imports_inside_functions_say_why():
    silent = []
    for m, found in IMPORTS.items():
        lines = MODULES[m].read_text().splitlines()
        for t, _, line, inside in found:
            if inside and t != "simplexspline._version":
                here, above = lines[line - 1], lines[line - 2] if line > 1 else ""
                if "#" not in here and not above.strip().startswith("#"):
                    silent.append(f"{m}:{line} imports {t} inside a function without a reason")
    assert silent == []


def test_no_reexport_shims_in_working_modules():
    shims = []
    for m, path in MODULES.items():
        if _is_package(m) or m in SHIMS:
            continue
        for no, line in enumerate(path.read_text().splitlines(), 1):
            if "re-export" in line and ("noqa" in line or line.lstrip().startswith("#")):
                shims.append(f"{m}:{no}: {line.strip()}")
    assert shims == []


@pytest.mark.parametrize("module", sorted(SHIMS))
def test_deprecated_paths_forward_public_names_with_a_warning(module):
    import importlib

    mod = importlib.import_module(module)
    names = dir(mod)
    assert names and all(not n.startswith("_") for n in names)
    with pytest.warns(DeprecationWarning, match=r"removed in simplexspline \d+\.\d+"):
        value = getattr(mod, names[0])
    assert value is not None
    with pytest.raises(AttributeError, match="has no attribute"):
        getattr(mod, "_private")

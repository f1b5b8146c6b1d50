"""The package's layout shows the pipeline (issue 23): its import graph is checked here.

Every ``import`` and ``from ... import`` in ``src/fuzzybrep`` counts, at module level or inside a
function: a lazy import is still a dependency. The rules:

- no import circles;
- no module outside ``commands/`` imports a command (``cli`` finds them by name);
- no ``formats`` module imports the mapping stages, the fuzzy map's algorithms or the uses: a
  format reads and writes maps and scans, it does not build them;
- at most 8 modules loose in ``src/fuzzybrep/``, no source file over 600 lines, no class over 250.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "fuzzybrep"


def _module(path: Path) -> str:
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module(p): p for p in SRC.rglob("*.py")}


def _imports(name: str, path: Path) -> set[str]:
    """The fuzzybrep modules ``name`` imports (``from . import x`` names module x when it is one)."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == "fuzzybrep"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.split(".")[0] == "fuzzybrep":
                target = node.module
            else:
                continue
            for a in node.names:
                sub = f"{target}.{a.name}"
                out.add(sub if sub in MODULES else target)
    return {m for m in out if m != name}


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle, as the modules along it, or None (depth-first search)."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph.get(m, ())):
            if state.get(n) == 1:
                return stack[stack.index(n):] + [n]
            if n not in state:
                found = visit(n)
                if found:
                    return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state:
            found = visit(m)
            if found:
                return found
    return None


def test_the_import_graph_is_read_and_has_the_modules():
    # the walk itself: a circle planted in a copy of the graph is found, the known edges are there
    assert "fuzzybrep.formats.files" in GRAPH["fuzzybrep.formats.compact"]
    assert "fuzzybrep.mapping.evidence" in GRAPH["fuzzybrep.mapping.build"]
    assert "fuzzybrep.scans.report" in GRAPH["fuzzybrep.scans.carmen"]
    planted = {**GRAPH, "fuzzybrep.brep": GRAPH["fuzzybrep.brep"] | {"fuzzybrep.mapping.build"}}
    assert _cycle(planted) is not None


def test_no_import_circles():
    assert _cycle(GRAPH) is None, " -> ".join(_cycle(GRAPH))


def test_no_module_outside_the_commands_imports_a_command():
    bad = [(m, n) for m, deps in GRAPH.items() if not m.startswith("fuzzybrep.commands")
           for n in deps if n.startswith("fuzzybrep.commands")]
    assert not bad


@pytest.mark.parametrize("stage", ["fuzzybrep.mapping", "fuzzybrep.use", "fuzzybrep.sim", "fuzzybrep.viewer",
                                   "fuzzybrep.fuzzy.sweep", "fuzzybrep.fuzzy.exact", "fuzzybrep.fuzzy.map"])
def test_formats_do_not_import_the_stages(stage):
    bad = [(m, n) for m, deps in GRAPH.items() if m.startswith("fuzzybrep.formats")
           for n in deps if n == stage or n.startswith(stage + ".")]
    assert not bad


def test_the_top_level_is_small_and_files_and_classes_are_short():
    loose = sorted(p.name for p in SRC.glob("*.py") if p.name != "__init__.py")
    assert len(loose) <= 8, loose
    long_files = {str(p.relative_to(SRC)): n for p in SRC.rglob("*.py") if (n := len(p.read_text().splitlines())) > 600}
    assert not long_files
    long_classes = {}
    for p in SRC.rglob("*.py"):
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ClassDef) and node.end_lineno - node.lineno + 1 > 250:
                long_classes[f"{p.relative_to(SRC)}:{node.name}"] = node.end_lineno - node.lineno + 1
    assert not long_classes


def test_the_readme_short_form_of_the_api_works():
    import fuzzybrep
    from fuzzybrep import FuzzyBRepMap, build_map, fuzzify, read_scans

    assert FuzzyBRepMap.__module__ == "fuzzybrep.fuzzy.map"
    assert build_map.__module__ == "fuzzybrep.mapping.build"
    assert fuzzify.__module__ == "fuzzybrep.fuzzy.map"
    assert read_scans.__module__ == "fuzzybrep.scans.read"
    with pytest.raises(AttributeError):
        fuzzybrep.no_such_name  # noqa: B018

"""The package keeps the layout of docs/architecture.md (issue 12): no import cycle, no import up a layer,
the C extension reached through one module, no private name across modules, and the picture in the document
drawn from the code as it is. The rules and the one layer table live in tools/import_graph.py.
"""
import ast
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def load_tool():
    spec = importlib.util.spec_from_file_location("import_graph", ROOT / "tools" / "import_graph.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


tool = load_tool()


@pytest.fixture(scope="module")
def graph():
    return tool.Graph(ROOT)   # raises UnknownModules naming any module the layer table does not place


def test_no_import_cycle(graph):
    assert graph.short_cycles() == []


def test_no_import_from_a_lower_layer_to_a_higher_one(graph):
    assert [f for f in graph.findings() if f.startswith("upward import")] == []


def test_core_is_imported_only_by_the_engine(graph):
    assert tool.ENGINE in graph.modules, "cgbound/_engine.py, the one seam to the C core, does not exist"
    importers = {a for a, b, *_ in graph.edges if b == tool.CORE}
    assert importers == {tool.ENGINE}


def test_no_private_name_imported_across_modules(graph):
    assert [f for f in graph.findings() if f.startswith("private name")] == []


def test_the_embedded_graph_is_current(graph):
    text = (ROOT / "docs" / "architecture.md").read_text()
    assert tool.embedded(text) == graph.block(), "run python tools/import_graph.py --write"


def test_sanitizer_redundant_names_name_tests_that_exist():
    # a renamed test would silently lose its marker and slow the sanitizer stage again
    from conftest import SANITIZER_REDUNDANT
    for name, tests in SANITIZER_REDUNDANT.items():
        path = Path(__file__).parent / name
        assert path.is_file(), name
        defined = {n.name for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.FunctionDef)}
        functions = {t.partition("[")[0] for t in tests or ()}
        assert functions <= defined, (name, functions - defined)
        # one parametrization ("test_x[a-b]"): it must be collected under that name, or it marks nothing
        for test in tests or ():
            if "[" in test:
                # -P: not the source tree's uncompiled cgbound from the working directory
                command = [sys.executable, "-P", "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider",
                           f"tests/{name}::{test}"]
                res = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
                assert res.returncode == 0 and f"{name}::{test}" in res.stdout, (name, test, res.stdout[-800:])


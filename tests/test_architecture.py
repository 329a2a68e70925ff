"""The package keeps the layout of docs/architecture.md (issue 12): no import cycle, no import up a layer,
the C extension reached through one module, no private name across modules, and the picture in the document
drawn from the code as it is. The rules and the one layer table live in tools/import_graph.py.
"""
import ast
import importlib.util
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


def test_python_bound_names_name_tests_that_exist():
    # a renamed test would silently lose its marker and slow the sanitizer stage again
    from conftest import PYTHON_BOUND
    for name, tests in PYTHON_BOUND.items():
        path = Path(__file__).parent / name
        assert path.is_file(), name
        defined = {n.name for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.FunctionDef)}
        assert set(tests or ()) <= defined, (name, set(tests) - defined)

"""tools/import_graph.py finds what it is meant to find, on small made-up packages (so that a clean report on
cgbound means something)."""
import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
spec = importlib.util.spec_from_file_location("import_graph", ROOT / "tools" / "import_graph.py")
tool = importlib.util.module_from_spec(spec)
spec.loader.exec_module(tool)


def package(tmp_path, files):
    for name, text in files.items():
        path = tmp_path / "cgbound" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return tool.Graph(tmp_path)


CLEAN = {
    "__init__.py": "from .coarse import coarse_grain\nfrom . import readers\n",
    "_engine.py": "from . import _core\n",
    "_validate.py": "",
    "box.py": "from ._validate import real_array\n",
    "fields.py": "from . import _engine\nfrom .box import Box\n",
    "coarse.py": "from .fields import derive\nimport cgbound.box as b\nx = b.Box\n",
    "readers/__init__.py": "from .hdf5 import Reader\n",
    "readers/hdf5.py": "from ..box import Box\nfrom ._sequence import Base\n",
    "readers/_sequence.py": "",
}


def test_a_clean_package_has_no_finding(tmp_path):
    graph = package(tmp_path, CLEAN)
    assert graph.findings() == []
    assert ("fields", "_engine") in {(a, b) for a, b, *_ in graph.edges}
    assert ("coarse", "box") in {(a, b) for a, b, *_ in graph.edges}          # absolute import
    assert ("readers.hdf5", "box") in {(a, b) for a, b, *_ in graph.edges}    # two dots up
    assert "m_readers" in graph.mermaid() and "m_readers_hdf5" not in graph.mermaid()   # collapsed


def test_a_cycle_through_a_lazy_import_is_found(tmp_path):
    files = dict(CLEAN, **{"coarse.py": "from .tiled import tile\n",
                           "tiled.py": "def f():\n    from .coarse import coarse_grain\n"})
    graph = package(tmp_path, files)
    assert graph.short_cycles() == [("coarse", "tiled")]
    assert any(f.startswith("import cycle: coarse -> tiled -> coarse") for f in graph.findings())


def test_an_upward_import_is_found(tmp_path):
    graph = package(tmp_path, dict(CLEAN, **{"box.py": "def f():\n    from .. import cgbound\n    from . import coarse\n"}))
    upward = {(a, b) for a, b, *_ in graph.upward()}
    assert ("box", "coarse") in upward


def test_core_outside_the_engine_and_private_names_are_found(tmp_path):
    graph = package(tmp_path, dict(CLEAN, **{"fields.py": "from . import _core\nfrom .box import _helper\n",
                                             "coarse.py": "from . import fields\ny = fields._outer\n"}))
    findings = graph.findings()
    assert any(f.startswith("_core imported outside _engine: cgbound/fields.py:1") for f in findings)
    assert any("fields uses box._helper" in f for f in findings)
    assert any("coarse uses fields._outer" in f for f in findings)


def test_an_unknown_module_is_named(tmp_path):
    with pytest.raises(tool.UnknownModules, match=r"cgbound/gizmo\.py \(module 'gizmo'\).*add each to LAYERS"):
        package(tmp_path, dict(CLEAN, **{"gizmo.py": ""}))


def test_check_reports_a_stale_document(tmp_path, capsys):
    package(tmp_path, CLEAN)
    (tmp_path / "docs").mkdir()
    doc = tmp_path / "docs" / "architecture.md"
    doc.write_text(f"# House\n\n{tool.START}\nold\n{tool.END}\n")
    assert tool.main(["--check", "--root", str(tmp_path)]) == 1
    assert "stale" in capsys.readouterr().out
    assert tool.main(["--write", "--root", str(tmp_path)]) == 0
    assert tool.main(["--check", "--root", str(tmp_path)]) == 0
    assert doc.read_text().startswith("# House\n\n<!-- import-graph:start -->")

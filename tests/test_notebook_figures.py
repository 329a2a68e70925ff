"""The notebook check of CI (tools/check_notebook_figures.py): a cell that makes a figure must show an image."""
import importlib.util
import json
import os

TOOL = os.path.join(os.path.dirname(__file__), os.pardir, "tools", "check_notebook_figures.py")
spec = importlib.util.spec_from_file_location("check_notebook_figures", TOOL)
check = importlib.util.module_from_spec(spec)
spec.loader.exec_module(check)


def notebook(tmp_path, source, outputs, executed=True):
    nb = {"cells": [{"cell_type": "code", "execution_count": 1 if executed else None, "metadata": {},
                     "outputs": outputs, "source": source}], "metadata": {}, "nbformat": 4, "nbformat_minor": 5}
    path = tmp_path / "n.ipynb"
    path.write_text(json.dumps(nb))
    return str(path)


def test_a_bare_figure_repr_fails_and_an_image_passes(tmp_path):
    text = [{"output_type": "execute_result", "data": {"text/plain": "<Figure size 1100x380 with 3 Axes>"}}]
    image = [{"output_type": "display_data", "data": {"image/png": "iVBORw0KGgo=", "text/plain": "<Figure>"}}]
    src = "fig, ax = plt.subplots()\nplot.profile(out, 'density', ax=ax)\nfig"
    assert check.main([notebook(tmp_path, src, text)]) == 1
    assert check.main([notebook(tmp_path, src, image)]) == 0


def test_cells_without_figures_need_no_image_and_unexecuted_notebooks_fail(tmp_path):
    assert check.main([notebook(tmp_path, "x = 1", [])]) == 0
    # plot.norm computes a value: no figure expected
    assert check.main([notebook(tmp_path, "t = plot.norm(out, 'stress')", [])]) == 0
    assert check.main([notebook(tmp_path, "x = 1", [], executed=False)]) == 1

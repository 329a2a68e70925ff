"""Check executed notebooks: every code cell that makes a figure shows it (has an image output).

    pytest --nbmake --overwrite notebooks/ && python tools/check_notebook_figures.py notebooks/*.ipynb

A cell that ends with a bare ``fig`` under a non-inline backend prints ``<Figure size ...>`` and
shows nothing, while nbmake still passes; this catches it. Exit status 1 lists the cells.
"""
import json
import re
import sys

#: source that makes a figure
MAKES_FIGURE = re.compile(r"plt\.(subplots|figure|show)\(|\bplot\.(profile|field_map|particles)\(|\.plot\(")
IMAGE_TYPES = ("image/png", "image/svg+xml", "image/jpeg")


def cells_without_figures(path):
    with open(path) as f:
        nb = json.load(f)
    missing, executed = [], False
    for k, cell in enumerate(nb["cells"]):
        if cell["cell_type"] != "code":
            continue
        executed |= cell.get("execution_count") is not None
        source = "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]
        if not MAKES_FIGURE.search(source):
            continue
        images = [o for o in cell.get("outputs", []) if any(t in o.get("data", {}) for t in IMAGE_TYPES)]
        if not images:
            missing.append(k)
    return executed, missing


def main(paths):
    bad = 0
    for path in paths:
        executed, missing = cells_without_figures(path)
        if not executed:
            print(f"{path}: not executed (run it first, e.g. pytest --nbmake --overwrite)")
            bad += 1
        elif missing:
            print(f"{path}: cells {missing} make a figure but show no image")
            bad += 1
        else:
            print(f"{path}: every figure shown")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

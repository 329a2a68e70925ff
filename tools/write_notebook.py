"""Write a notebook without outputs from a plain Python file with '# %%' / '# %% [markdown]' cells.

    python tools/write_notebook.py notebooks/src/02_boundary_2d.py notebooks/02_boundary_2d.ipynb
"""
import json
import sys


def cells(text):
    out, kind, lines = [], None, []

    def flush():
        if kind is not None:
            body = "\n".join(lines).strip("\n")
            if kind == "markdown":
                body = "\n".join(line[2:] if line.startswith("# ") else line.lstrip("#") for line in body.splitlines())
                out.append({"cell_type": "markdown", "metadata": {}, "source": body})
            else:
                out.append({"cell_type": "code", "execution_count": None, "metadata": {}, "outputs": [],
                            "source": body})
    for line in text.splitlines():
        if line.startswith("# %%"):
            flush()
            kind, lines = ("markdown" if "[markdown]" in line else "code"), []
        else:
            lines.append(line)
    flush()
    return out


def main(src, dst):
    nb = {"cells": cells(open(src).read()), "metadata": {
        "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
        "language_info": {"name": "python"}}, "nbformat": 4, "nbformat_minor": 5}
    for k, cell in enumerate(nb["cells"]):
        cell["id"] = f"cell-{k}"
    with open(dst, "w") as f:
        json.dump(nb, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main(*sys.argv[1:])

"""Sphinx configuration of cgbound's documentation site.

Build (from the repository root, with the package installed and the notebooks executed first):

    pytest --nbmake --overwrite notebooks/
    sphinx-build -W --keep-going -b html docs docs/_build/html

The notebooks are rendered with the outputs they carry and are never executed here: the build copies
``notebooks/*.ipynb`` into ``docs/gallery/`` and fails if a notebook has no outputs, so a site cannot be
published with empty notebooks. ``CGBOUND_NOTEBOOKS=dir`` takes the executed notebooks from another
directory instead.
"""
import base64
import json
import os
from pathlib import Path

from sphinx.util import logging

import cgbound

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
NOTEBOOKS = Path(os.environ.get("CGBOUND_NOTEBOOKS", ROOT / "notebooks"))
GALLERY = DOCS / "gallery"

project = "cgbound"
author = "the cgbound developers"
copyright = "2026, the cgbound developers"
release = cgbound.__version__
version = release

extensions = [
    "myst_nb",                       # Markdown pages (MyST) and notebooks, rendered from their stored outputs
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",                      # the package's docstrings are numpydoc style
    "sphinx.ext.mathjax",
    "sphinxcontrib.mermaid",         # the diagrams of architecture.md
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]
templates_path = ["_templates"]

# MyST: $...$ math as in theory.md, GitHub-style heading anchors (theory.md#momentum-balance)
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
myst_fence_as_directive = ["mermaid"]   # architecture.md's diagrams, drawn by mermaid.js in the browser
nb_execution_mode = "off"            # CI executes the notebooks (nbmake) before the build; never here
nb_merge_streams = True

# API reference: one page per public object, generated from the docstrings at every build
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": True, "member-order": "bysource"}
autodoc_typehints = "none"
numpydoc_show_class_members = False  # autodoc's :members: lists them; numpydoc would list them twice
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

html_theme = "furo"
html_title = f"cgbound {release}"
html_static_path = ["_static"]
html_css_files = ["cgbound.css"]
html_show_sourcelink = False

logger = logging.getLogger("cgbound.docs")


def image_outputs(notebook):
    """The PNG outputs of a notebook, in order."""
    return [output["data"]["image/png"] for cell in notebook["cells"] if cell["cell_type"] == "code"
            for output in cell.get("outputs", []) if "image/png" in output.get("data", {})]


def copy_notebooks(app):
    """Copy the executed notebooks into the gallery and write each one's first figure as its thumbnail."""
    thumbs = GALLERY / "thumbnails"
    thumbs.mkdir(parents=True, exist_ok=True)
    sources = sorted(NOTEBOOKS.glob("*.ipynb"))
    if not sources:
        logger.warning(f"no notebooks in {NOTEBOOKS}")
    for source in sources:
        notebook = json.loads(source.read_text())
        if not any(cell.get("outputs") for cell in notebook["cells"] if cell["cell_type"] == "code"):
            logger.warning(f"{source} has no outputs: execute the notebooks first "
                           f"(pytest --nbmake --overwrite notebooks/)")
        images = image_outputs(notebook)
        if images:
            (thumbs / f"{source.stem}.png").write_bytes(base64.b64decode(images[0]))
        # the notebooks link to the pages as ../docs/page.md; from docs/gallery/ that is ../page.md
        for cell in notebook["cells"]:
            if cell["cell_type"] == "markdown":
                text = "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]
                cell["source"] = text.replace("](../docs/", "](../")
        (GALLERY / source.name).write_text(json.dumps(notebook, indent=1))


def setup(app):
    app.connect("builder-inited", copy_notebooks)

"""Sphinx configuration of the backlash-df documentation.

Build (warnings are errors, as in CI)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

Why this stack: Sphinx is the documentation tool of the scientific Python world
(numpy, scipy, matplotlib, python-control use it); numpydoc renders the numpydoc
docstrings the package is written in; myst-nb reads Markdown pages and renders
the Jupyter notebooks of ``notebooks/`` with their outputs; the pydata theme is the
one those projects share, so the pages look like the references users already read.
"""

import os
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))

import backlash_df  # noqa: E402

project = "backlash-df"
author = "backlash-df developers"
copyright = "backlash-df developers"
release = version = backlash_df.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    # MathJax 3.2.2 shipped in the package and copied into _static/mathjax: the math
    # renders with no network (the pages are read on plant floors); it sets
    # mathjax_path = "mathjax/tex-chtml.js".  tests/test_docs.py checks that no page
    # loads a remote script.
    "sphinx-mathjax-offline",
    "numpydoc",
    "myst_nb",
    "sphinx_click",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "examples", "make_figures.py", "**.ipynb_checkpoints"]
templates_path = []
html_static_path = ["_static"]

# --------------------------------------------------------------- notebooks
# The notebooks live in ../notebooks (run there by ``pytest --nbmake``); Sphinx
# only reads files below docs/, so they are copied into docs/notebooks/
# (git-ignored) at every build.  They are stored without outputs, so the build
# executes them: "force" (never a stale cache), with a per-cell timeout, and a
# failing cell fails the build.  See docs/notebooks.md for the time this costs.
_NOTEBOOK_COPY = DOCS / "notebooks"
if _NOTEBOOK_COPY.exists():
    shutil.rmtree(_NOTEBOOK_COPY)
_NOTEBOOK_COPY.mkdir()
for _notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
    shutil.copy2(_notebook, _NOTEBOOK_COPY / _notebook.name)
# The notebooks open their rigs as "../examples/...": give the copies the same
# neighbour (docs/examples, git-ignored, not a page source).
_EXAMPLES_COPY = DOCS / "examples"
if _EXAMPLES_COPY.exists():
    shutil.rmtree(_EXAMPLES_COPY)
shutil.copytree(ROOT / "examples", _EXAMPLES_COPY)

nb_execution_mode = os.environ.get("BACKLASH_DF_DOCS_EXECUTE", "force")
nb_execution_timeout = 180
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True
nb_kernel_rgx_aliases = {".*": "python3"}

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_dmath_double_inline = True
myst_heading_anchors = 3

# --------------------------------------------------------------- API reference
autosummary_generate = False
autodoc_default_options = {"members": True, "member-order": "bysource"}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
numpydoc_class_members_toctree = False

# --------------------------------------------------------------- HTML
html_theme = "pydata_sphinx_theme"
html_title = f"backlash-df {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_sidebars = {"**": ["sidebar-nav-bs"]}


# --------------------------------------------------------------- math
def _tagged_math_unsplit(app, doctree, docname):
    r"""Display math holding both ``\\`` and the paper's ``\tag{14}``: Sphinx wraps a block with
    ``\\`` in ``split``, where MathJax refuses ``\tag`` (the equation showed as an error); such
    blocks are emitted as ``\[ ... \]`` themselves.  tests/test_docs.py renders the theory page."""
    from docutils import nodes

    for node in doctree.findall(nodes.math_block):
        text = node.astext()
        if r"\tag" in text and r"\\" in text and not node.get("nowrap"):
            node["nowrap"] = True
            node[:] = [nodes.Text(rf"\[{text}\]")]


def setup(app):
    app.connect("doctree-resolved", _tagged_math_unsplit)

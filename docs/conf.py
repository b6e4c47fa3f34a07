"""Sphinx configuration of roa's documentation (``sphinx-build -W --keep-going -b html docs
docs/_build/html``). The API reference is generated from the numpydoc docstrings, the CLI
reference from ``roa.cli.build_parser``."""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")

import roa  # noqa: E402

project = "roa"
author = "roa developers"
copyright = "2026, roa developers"
release = version = roa.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinxarg.ext",
    "roa_docs",  # _ext/roa_docs.py: the examples' numbers as tables
    "roa_api",  # _ext/roa_api.py: docstrings of constants and cfuncs of the lazy packages
]
autosummary_generate = True
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_typehints = "none"  # the numpydoc docstrings state the types
autodoc_member_order = "bysource"
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False
napoleon_use_param = False  # a definition list: no cross-reference made of each word of a type
napoleon_use_ivar = True  # "Attributes" as fields, not a second description of each member
napoleon_attr_annotations = False
nitpicky = False
# CLI help texts (rendered as reST by sphinx-argparse) write |theta| and |u| for absolute values,
# the docstrings of roa.lyapunov.symmetric_extent and roa.search.sector |s|
rst_prolog = """
.. |theta| replace:: \\|theta\\|
.. |u| replace:: \\|u\\|
.. |s| replace:: \\|s\\|
"""
exclude_patterns = ["_build"]
# option names such as --t-final stay two hyphens (smart quotes would make them an en dash)
smartquotes = False
html_static_path = ["_static"]
html_css_files = ["roa.css"]
html_theme = "alabaster"
html_title = f"roa {release}"
html_theme_options = {"description": "region-of-attraction verification", "page_width": "1100px"}

"""Sphinx configuration of the gyro_calib documentation site (MyST Markdown pages).

Built by ``./run.sh docs`` (``sphinx-build -W --keep-going -n -b html docs docs/_build/html``);
the suite builds it the same way (test/test_docs_build.py). The reference pages under
reference/generated/ are written from the code at every build by ``_ext/gyro_docs.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / '_ext'))
sys.path.insert(0, str(DOCS.parent))

from gyro_calib import __version__  # noqa: E402

project = 'gyro_calib'
author = 'gyro_calib developers'
copyright = '2026, gyro_calib developers'  # noqa: A001 (Sphinx's name)
release = version = __version__

extensions = ['myst_parser', 'gyro_docs']
source_suffix = {'.md': 'markdown'}
root_doc = 'index'
exclude_patterns = ['_build', '.gitignore']

myst_enable_extensions = ['colon_fence', 'deflist']
myst_heading_anchors = 3
myst_footnote_transition = False

nitpicky = True
suppress_warnings: list[str] = []

html_theme = 'furo'
html_title = f'gyro_calib {release}'
html_static_path: list[str] = []
html_last_updated_fmt = None
pygments_style = 'sphinx'

"""Offer every executed chapter as a ``.ipynb`` in the page's download menu.

The chapters are MyST Markdown notebooks, so the theme's download menu would offer
only the ``.md`` source. MyST-NB writes each executed notebook to
``_build/jupyter_execute/<page>.ipynb``; this extension copies it next to the
page's sources in the built site and names it in the page context, where
sphinx-book-theme turns it into a ".ipynb" entry of the download menu.
"""

from __future__ import annotations

import shutil
from pathlib import Path


def _offer_notebook(app, pagename, templatename, context, doctree):
    executed = Path(app.outdir).parent / "jupyter_execute" / f"{pagename}.ipynb"
    if app.builder.format != "html" or not executed.exists():
        return
    target = Path(app.outdir) / "_sources" / f"{pagename}.ipynb"
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(executed, target)
    context["ipynb_source"] = f"{pagename}.ipynb"


def setup(app):
    # before the theme builds its header buttons (priority 501)
    app.connect("html-page-context", _offer_notebook, priority=500)
    return {"parallel_read_safe": True, "parallel_write_safe": True}

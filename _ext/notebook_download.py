"""Offer every executed chapter as a ``.ipynb`` in the page's download menu.

The chapters are MyST Markdown notebooks, so the theme's download menu would offer
only the ``.md`` source. This extension takes the page's executed notebook from
the execution cache (``_build/.jupyter_cache``: outputs merged into the page's
source, as a reader's kernel would leave it), writes it next to the page's
sources in the built site and names it in the page context, where
sphinx-book-theme turns it into a ".ipynb" entry of the download menu. The download is a
plain notebook: the source's jupytext header is dropped. (The copy
MyST-NB leaves in ``_build/jupyter_execute`` has no outputs when the page came
from the cache.)
"""

from __future__ import annotations

from pathlib import Path


def _executed_notebook(app, pagename):
    """The page's notebook with its cached outputs, or None if it is not a cached notebook."""
    import jupytext
    import nbformat
    from jupyter_cache import get_cache

    source = Path(app.env.doc2path(pagename))
    if source.suffix != ".md" or "kernelspec:" not in source.read_text(encoding="utf-8")[:2000]:
        return None
    cache_path = Path(app.outdir).parent / ".jupyter_cache"
    if not cache_path.exists():
        return None
    nb = jupytext.read(source)
    try:
        _, merged = get_cache(str(cache_path)).merge_match_into_notebook(nb)
    except KeyError:
        return None
    # A plain notebook: the MyST source's jupytext header (``formats: md:myst``) would make
    # JupyterLab with jupytext look for a paired ``.md`` beside the download and refuse it.
    merged.metadata.pop("jupytext", None)
    return nbformat.writes(merged)


def _offer_notebook(app, pagename, templatename, context, doctree):
    if app.builder.format != "html":
        return
    text = _executed_notebook(app, pagename)
    if text is None:
        return
    target = Path(app.outdir) / "_sources" / f"{pagename}.ipynb"
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(text, encoding="utf-8")
    context["ipynb_source"] = f"{pagename}.ipynb"


def setup(app):
    # before the theme builds its header buttons (priority 501)
    app.connect("html-page-context", _offer_notebook, priority=500)
    return {"parallel_read_safe": True, "parallel_write_safe": True}

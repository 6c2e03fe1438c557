"""Sphinx extension of the radarfusion book: static pages that carry nothing dead.

Two things Jupyter Book 1 puts on every page that the book does not use:

* **Widget state.** An executed notebook stores the state of every ipywidgets
  model its kernel created in ``metadata.widgets`` (nbclient's default
  ``store_widget_state=True``, used both by the chapter tests and by
  ``jupyter-book build``), even when the cell that displayed the widget is
  tagged ``remove-cell``. myst-nb embeds it in the page as a
  ``<script type="application/vnd.jupyter.widget-state+json">`` (tens of KB
  per page). Here, when a page is read, the state is dropped if the page shows
  no widget view, and otherwise cut down to the models its views reference
  (with everything those models reference in turn).
* **Thebe.** sphinx-thebe is always loaded by Jupyter Book and adds to every
  page an inline script declaring ``const THEBE_JS_URL`` (a CDN address), twice
  when the extension is set up twice (a console error), plus
  ``sphinx-thebe.js`` and ``sphinx-thebe.css``. The book has no live code cells
  on its pages (``launch_buttons: thebe: false``), so these are removed from
  every page.

And one thing it numbers differently:

* **Exercises on unnumbered pages.** Sphinx numbers enumerable nodes per chapter on
  the numbered parts of ``_toc.yml`` (Exercise 1.1, 1.2, ...), but every page
  outside them shares one counter keyed by the empty section number, so the
  introduction's exercises were 1-2 and the Monte-Carlo page's 3-4. Here each
  unnumbered page counts its own exercises from 1, in the order Sphinx met them.

Registered in ``_config.yml`` under ``sphinx: local_extensions:``.
"""

from __future__ import annotations

import json
import re

from docutils import nodes

WIDGET_STATE = "application/vnd.jupyter.widget-state+json"
WIDGET_VIEW = "application/vnd.jupyter.widget-view+json"
_MODEL_REF = re.compile(r"IPY_MODEL_([0-9a-fA-F]+)")


def widget_views(doctree: nodes.document) -> set[str]:
    """Model ids of the widget views a page shows (its un-removed widget outputs)."""
    ids = set()
    for node in doctree.findall(nodes.container):
        if node.get("mime_type") != WIDGET_VIEW:
            continue
        ids.add("")  # a view whose id cannot be read keeps the whole state
        for raw in node.findall(nodes.raw):
            # the view's JSON, possibly itself JSON-quoted (escaped quotes)
            ids.update(re.findall(r'model_id[\\"\s:]*([0-9a-fA-F]{8,})', raw.astext()))
    return ids


def reachable_state(state: dict, roots: set[str]) -> dict:
    """The models of `state` that `roots` reference, directly or through other models."""
    keep, todo = set(), [r for r in roots if r in state]
    while todo:
        mid = todo.pop()
        if mid in keep:
            continue
        keep.add(mid)
        todo.extend(m for m in _MODEL_REF.findall(json.dumps(state[mid])) if m in state)
    return {k: v for k, v in state.items() if k in keep}


def prune_widget_state(app, doctree: nodes.document) -> None:
    """Drop (or cut down) the widget state myst-nb registered for this page."""
    env = app.env
    meta = getattr(env, "nb_metadata", {}).get(env.docname, {})
    js_files = meta.get("js_files", {})
    if "ipywidgets_state" not in js_files:
        return
    views = widget_views(doctree)
    if not views:
        for key in [k for k in js_files if k.startswith("ipywidgets_")]:
            del js_files[key]
        return
    if "" in views and len(views) == 1:
        return
    uri, kwargs = js_files["ipywidgets_state"]
    bundle = json.loads(kwargs["body"].replace(r"<\/script>", "</script>"))
    bundle["state"] = reachable_state(bundle.get("state", {}), views - {""})
    kwargs = dict(kwargs, body=json.dumps(bundle).replace("</script>", r"<\/script>"))
    js_files["ipywidgets_state"] = (uri, kwargs)


def _is_thebe(asset) -> bool:
    filename = str(getattr(asset, "filename", asset) or "")
    body = getattr(asset, "attributes", {}).get("body", "")
    return "sphinx-thebe" in filename or "THEBE_JS_URL" in body


def drop_thebe(app, pagename, templatename, context, doctree) -> None:
    """Remove sphinx-thebe's config script, loader and stylesheet from the page."""
    for key in ("script_files", "css_files"):
        if key in context:
            context[key] = [a for a in context[key] if not _is_thebe(a)]


#: Enumerable node types numbered per page on unnumbered pages.
PER_PAGE_FIGTYPES = ("exercise",)


def number_per_page(fignumbers: dict, secnumbers: dict,
                    figtypes=PER_PAGE_FIGTYPES) -> list[str]:
    """Renumber `figtypes` from 1 on each page that has no section number.

    `fignumbers` is Sphinx's ``env.toc_fignumbers`` (docname -> figtype -> id ->
    number tuple), changed in place; `secnumbers` is ``env.toc_secnumbers``.
    Returns the pages whose numbers changed.
    """
    changed = []
    for docname, by_type in fignumbers.items():
        if any(secnumbers.get(docname, {}).values()):
            continue  # a page of a numbered part: per chapter, as Sphinx does
        for figtype in figtypes:
            ids = by_type.get(figtype)
            if not ids:
                continue
            renumbered = {fid: (i,) for i, fid in enumerate(ids, start=1)}
            if renumbered != ids:
                by_type[figtype] = renumbered
                changed.append(docname)
    return changed


def renumber_unnumbered_pages(app, env) -> list[str]:
    """``env-get-updated``: after Sphinx numbers the figures, number exercises per page."""
    return number_per_page(env.toc_fignumbers, env.toc_secnumbers)


def setup(app):
    app.connect("doctree-read", prune_widget_state)
    # after Sphinx's toctree collector has assigned the numbers (default priority 500)
    app.connect("env-get-updated", renumber_unnumbered_pages, priority=900)
    # after sphinx-thebe and myst-nb have added their assets (default priority 500)
    app.connect("html-page-context", drop_thebe, priority=900)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}

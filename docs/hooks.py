"""MkDocs hooks (mkdocs.yml ``hooks:``): links from pages to repository files outside docs/.

The pages are also read on GitHub, where ``[the scenario](../configs/landing_95ghz.yaml)`` opens
the file. The site holds only docs/, so such a link is written as the file's repository path in
code (``configs/landing_95ghz.yaml``), which a reader finds in their checkout, and a link to a file
that does not exist is a warning, which ``strict: true`` turns into a failed build.
"""

from __future__ import annotations

import logging
import posixpath
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
log = logging.getLogger("mkdocs.plugins.pmmw")

# pages generated from a file outside docs/: the folder their relative links start from
SOURCES = {"shipped-scenes.md": "scenes", "changelog.md": "."}
LINK = re.compile(r"(?<!!)\[([^\]]+)\]\((?!https?:|mailto:|#)([^)\s]+)\)")


def _outside(page_uri: str, target: str) -> str | None:
    """The repository path of ``target`` when it lies outside docs/, else None (a page's own link)."""
    base = SOURCES.get(page_uri, posixpath.join("docs", posixpath.dirname(page_uri)))
    path = posixpath.normpath(posixpath.join(base, target.split("#")[0]))
    if path == "docs" or path.startswith("docs/"):
        return None
    return path


def on_page_markdown(markdown: str, page, config, files) -> str:
    uri = page.file.src_uri

    def fix(m: re.Match) -> str:
        text, target = m.group(1), m.group(2)
        path = _outside(uri, target)
        if path is None:
            if uri in SOURCES:  # a page from outside docs/ linking into it: the link from where the page is
                file, _, anchor = target.partition("#")
                inside = posixpath.normpath(posixpath.join(SOURCES[uri], file))[len("docs/") :]
                rel = posixpath.relpath(inside, posixpath.dirname(uri) or ".")
                return f"[{text}]({rel}{'#' + anchor if anchor else ''})"
            return m.group(0)
        if path.startswith("..") or not (ROOT / path).exists():
            log.warning("%s: link to %s, which is not in the repository", uri, target)
            return m.group(0)
        shown = f"`{path}`"
        return shown if text.strip("`") == path or text.strip("`") == target else f"{text} ({shown})"

    out, fence = [], False
    for line in markdown.split("\n"):
        if line.lstrip().startswith(("```", "~~~")):
            fence = not fence
        out.append(line if fence else LINK.sub(fix, line))
    return "\n".join(out)

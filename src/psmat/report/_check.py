""":func:`check_page`: whether an HTML text holds only what a page of :func:`render_report` can.

A page is read here when it was made where it is not trusted to run anything in a browser: a
per-subject page drawn by a Dask worker (:mod:`psmat.study` (``_cluster.py``)). Its vocabulary is
closed (``_html.py``): the tags and attributes below, this package's own style sheet, figures as
``data:image/png;base64`` of a well-formed PNG. Anything else — a script, an event handler, a
link, a frame, a ``<meta http-equiv>``, a comment, another style sheet — is refused.
"""

from __future__ import annotations

import base64
import binascii
import re
from html.parser import HTMLParser

from .._png import check_png
from ._html import _CSS

__all__ = ["check_page"]

#: each tag a page may hold, with the attributes it may carry
_ALLOWED: dict[str, frozenset[str]] = {
    **dict.fromkeys(("head", "title", "style", "body", "h1", "h2", "h3", "b", "table", "thead", "tbody", "tr", "th",
                     "summary"), frozenset()),
    "html": frozenset({"lang"}), "meta": frozenset({"charset", "name", "content"}), "section": frozenset({"id"}),
    "p": frozenset({"class"}), "td": frozenset({"class"}), "details": frozenset({"open"}),
    "img": frozenset({"alt", "src"}),
}
_PNG_SRC = re.compile(r"data:image/png;base64,([A-Za-z0-9+/]+={0,2})")
_CONTROL = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")
#: the largest page accepted (characters): a page of a few sessions is a few MiB of base64 figures
MAX_PAGE_CHARS = 256 << 20


class _Checker(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.doctype = False
        self.style: list[str] | None = None  # the text of the <style> being read
        self.styles = 0

    def handle_decl(self, decl: str) -> None:
        if decl.lower() != "doctype html" or self.doctype:
            raise ValueError(f"a declaration <!{decl[:40]}> that is not the page's one <!DOCTYPE html>")
        self.doctype = True

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if not self.doctype:
            raise ValueError("a page must begin with <!DOCTYPE html>")
        if tag not in _ALLOWED:
            raise ValueError(f"a page holds a <{tag[:40]}> tag")
        names = [a for a, _ in attrs]
        bad = sorted(set(names) - _ALLOWED[tag])
        if bad or len(set(names)) != len(names):
            raise ValueError(f"a <{tag}> tag with the attribute(s) {', '.join(bad[:5]) or 'twice the same'}")
        values = dict(attrs)
        if tag == "meta" and not (values == {"charset": "utf-8"} or
                                  (set(values) == {"name", "content"} and values["name"] == "viewport")):
            raise ValueError("a <meta> tag other than charset=utf-8 or the viewport")
        if tag == "img":
            m = _PNG_SRC.fullmatch(values.get("src") or "")
            if m is None:
                raise ValueError("an <img> whose src is not data:image/png;base64")
            try:
                check_png(base64.b64decode(m.group(1), validate=True))
            except (binascii.Error, ValueError) as exc:
                raise ValueError(f"an <img> that is no PNG: {exc}") from None
        if tag == "style":
            self.style, self.styles = [], self.styles + 1

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.handle_starttag(tag, attrs)
        if tag == "style":
            self.handle_endtag(tag)

    def handle_endtag(self, tag: str) -> None:
        if tag not in _ALLOWED:
            raise ValueError(f"a page holds a </{tag[:40]}> tag")
        if tag == "style":
            if self.style is None or "".join(self.style) != _CSS:
                raise ValueError("a page whose style sheet is not psmat's")
            self.style = None

    def handle_data(self, data: str) -> None:
        if self.style is not None:
            self.style.append(data)

    def handle_comment(self, data: str) -> None:
        raise ValueError("a page holds a comment")

    def handle_pi(self, data: str) -> None:
        raise ValueError("a page holds a processing instruction")

    def unknown_decl(self, data: str) -> None:
        raise ValueError("a page holds an unknown declaration")


def check_page(text: object) -> str:
    """``text`` when it is an HTML page made only of what :func:`render_report` writes, else
    ValueError (one line): see the module docstring for what is allowed.

    Parameters
    ----------
    text : str
        The page.

    Raises
    ------
    ValueError
        Not text, over :data:`MAX_PAGE_CHARS`, a NUL or another control character (tab and
        line ends aside), or anything outside the page's vocabulary.
    """
    if not isinstance(text, str):
        raise ValueError(f"a page must be text, got {type(text).__name__}")
    if len(text) > MAX_PAGE_CHARS:
        raise ValueError(f"a page of {len(text)} characters, more than {MAX_PAGE_CHARS}")
    if _CONTROL.search(text):
        raise ValueError("a page holds a control character")
    parser = _Checker()
    parser.feed(text)
    parser.close()
    if not parser.doctype or parser.styles != 1 or parser.style is not None:
        raise ValueError("a page without its <!DOCTYPE html> and its one closed <style>")
    return text

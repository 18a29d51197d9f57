"""The identification report as one document, rendered to HTML and to Markdown.

The report's sections build a list of blocks (:class:`Heading`, :class:`Paragraph`,
:class:`BulletList`, :class:`Table`, :class:`Code`, :class:`Figure`, :class:`Alert`,
:class:`Nav`, :class:`Footer`); :func:`to_html` and :func:`to_markdown` render the same list.
Text in a block is always data, never markup: the HTML renderer escapes it with
:func:`html.escape`, the Markdown renderer so that it can make no element, link, image,
emphasis or code span of its own (:func:`~simplexspline.aero.report.markup._md_text`).
Inline emphasis is asked for with :class:`Emph`, :class:`Strong` and :class:`CodeSpan`.

A block given ``only="html"`` or ``only="md"`` appears in that format alone: the HTML page
is the full report, the Markdown file a summary beside the figure files (for instance the
navigation bar and the collapsible JSON dumps are HTML only).
"""

from __future__ import annotations

import base64
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from urllib.parse import quote

from simplexspline.aero.report.markup import _cell, _esc, _md, _md_code, _md_text

__all__ = ["Alert", "BulletList", "Code", "CodeSpan", "Emph", "Figure", "Footer", "Heading", "Nav",
           "Paragraph", "Strong", "Table", "to_html", "to_markdown"]


# ---------------------------------------------------------------------------- inline
@dataclass(frozen=True)
class Emph:
    """Emphasised text (``<em>``; ``*text*`` in Markdown, where CommonMark needs a blank or
    punctuation just outside the asterisks: write ``["a ", Emph(x), " b"]``)."""

    text: str


@dataclass(frozen=True)
class Strong:
    """Strong text (``<strong>``; ``**text**`` in Markdown, blanks around as for Emph)."""

    text: str


@dataclass(frozen=True)
class CodeSpan:
    """Literal text in a code span (``<code>``; backticks longer than any run inside)."""

    text: str


def _parts(content) -> tuple:
    """Inline content (text, a marker, or a sequence of them) as a tuple of parts."""
    return (content,) if isinstance(content, (str, Emph, Strong, CodeSpan)) else tuple(content)


def _inline_html(content) -> str:
    out = []
    for part in _parts(content):
        if isinstance(part, Emph):
            out.append(f"<em>{_esc(part.text)}</em>")
        elif isinstance(part, Strong):
            out.append(f"<strong>{_esc(part.text)}</strong>")
        elif isinstance(part, CodeSpan):
            out.append(f"<code>{_esc(part.text)}</code>")
        else:
            out.append(_esc(part))
    return "".join(out)


def _inline_md(content) -> str:
    out = []
    for part in _parts(content):
        if isinstance(part, (Emph, Strong)):
            # blanks just inside the asterisks would undo the emphasis (CommonMark)
            text = _md_text(part.text).strip()
            mark = "*" if isinstance(part, Emph) else "**"
            out.append(f"{mark}{text}{mark}" if text else "")
        elif isinstance(part, CodeSpan):
            out.append(_md_code(part.text))
        else:
            out.append(_md_text(part))
    return "".join(out)


# ---------------------------------------------------------------------------- blocks
@dataclass(frozen=True)
class Heading:
    """A section heading of ``level`` 1..6; ``anchor`` is its HTML id."""

    level: int
    text: str
    anchor: str | None = None
    only: str | None = None


@dataclass(frozen=True)
class Paragraph:
    """A paragraph of inline content."""

    content: object
    only: str | None = None


@dataclass(frozen=True)
class BulletList:
    """An unordered list; each item is inline content."""

    items: Sequence
    only: str | None = None


@dataclass(frozen=True)
class Table:
    """A table of text cells; a cell may be ``(text, css class)``.

    ``left`` are the indices of left-aligned columns, ``classes`` one css class per row
    (HTML only; Markdown tables carry text alone).
    """

    head: Sequence[str]
    rows: Sequence[Sequence]
    left: tuple = ()
    classes: Sequence[str] | None = None
    only: str | None = None


@dataclass(frozen=True)
class Code:
    """Preformatted text; with ``summary`` it folds away in HTML (``<details>``)."""

    text: str
    summary: str | None = None
    only: str | None = None


@dataclass(frozen=True)
class Figure:
    """A rendered figure: PNG bytes and caption. Embedded as a base64 data URI in HTML,
    linked as ``figures/<name>.png`` in Markdown."""

    name: str
    caption: str
    png: bytes = field(repr=False)
    only: str | None = None

    @property
    def path(self) -> str:
        """Its path relative to the report (``figures/<name>.png``)."""
        return f"figures/{self.name}.png"


@dataclass(frozen=True)
class Alert:
    """A highlighted warning (``> **Warning:** ...`` in Markdown)."""

    text: str
    only: str | None = None


@dataclass(frozen=True)
class Nav:
    """Links to anchors of the page, as ``(anchor, text)`` pairs (HTML only)."""

    links: Sequence[tuple[str, str]]
    only: str | None = "html"


@dataclass(frozen=True)
class Footer:
    """The closing line after a rule."""

    text: str
    only: str | None = None


def _shown(block, kind: str) -> bool:
    only = getattr(block, "only", None)
    return only is None or only == kind


# ---------------------------------------------------------------------------- HTML
def _html_cls(*names: str) -> str:
    names = " ".join(n for n in names if n)
    return f' class="{_esc(names)}"' if names else ""


def _html_table(t: Table) -> str:
    out = ["<table><thead><tr>"]
    out += [f"<th{_html_cls('l' if i in t.left else '')}>{_esc(h)}</th>"
            for i, h in enumerate(t.head)]
    out.append("</tr></thead><tbody>")
    for k, row in enumerate(t.rows):
        out.append(f"<tr{_html_cls(t.classes[k] if t.classes else '')}>")
        for i, x in enumerate(row):
            text, c = _cell(x)
            out.append(f"<td{_html_cls('l' if i in t.left else '', c)}>{_esc(text)}</td>")
        out.append("</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def _html_block(b) -> str:
    if isinstance(b, Heading):
        anchor = f' id="{_esc(b.anchor)}"' if b.anchor is not None else ""
        return f"<h{b.level}{anchor}>{_esc(b.text)}</h{b.level}>"
    if isinstance(b, Paragraph):
        return f"<p>{_inline_html(b.content)}</p>"
    if isinstance(b, BulletList):
        return "<ul>" + "".join(f"<li>{_inline_html(i)}</li>" for i in b.items) + "</ul>"
    if isinstance(b, Table):
        return _html_table(b)
    if isinstance(b, Code):
        pre = f"<pre>{_esc(b.text)}</pre>"
        return (f"<details><summary>{_esc(b.summary)}</summary>{pre}</details>"
                if b.summary is not None else pre)
    if isinstance(b, Figure):
        data = base64.b64encode(b.png).decode("ascii")
        return (f'<figure><img alt="{_esc(b.caption)}" src="data:image/png;base64,{data}">'
                f"<figcaption>{_esc(b.caption)}</figcaption></figure>")
    if isinstance(b, Alert):
        return f'<div class="warn">{_esc(b.text)}</div>'
    if isinstance(b, Nav):
        return "<nav>" + " ".join(f'<a href="#{_esc(a)}">{_esc(t)}</a>'
                                  for a, t in b.links) + "</nav>"
    if isinstance(b, Footer):
        return f"<hr><p><small>{_esc(b.text)}</small></p>"
    raise TypeError(f"not a report block: {type(b).__name__}")


def to_html(blocks: Sequence, *, title: str, css: str = "") -> str:
    """The blocks as one self-contained HTML page (UTF-8, inline style sheet).

    Every text is escaped (``&``, ``<``, ``>``, quotes), so data never become markup.
    """
    body = "\n".join(_html_block(b) for b in blocks if _shown(b, "html"))
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{_esc(title)}</title><style>{css}</style></head><body>\n"
            + body + "\n</body></html>\n")


# ---------------------------------------------------------------------------- Markdown
#: What starts a block when it begins a line: heading, quote, list item, thematic break,
#: setext underline, table, fence, or more than three spaces of indentation (code).
_MD_BLOCK_START = re.compile(r"^(?:[ \t]*)(?:([#>+\-=~|:])|(\d{1,9})([.)]))")


def _md_lead(text: str) -> str:
    """Markdown text that begins a block, with a leading block marker escaped and leading
    blanks removed, so data at the start of a paragraph or list item stay text."""
    text = text.lstrip(" \t")
    m = _MD_BLOCK_START.match(text)
    if m is None:
        return text
    if m.group(1):
        return "\\" + text
    return f"{m.group(2)}\\{m.group(3)}{text[m.end():]}"


def _md_fence(text: str) -> str:
    """A code fence longer than any run of backticks in ``text`` (at least three), so the
    text cannot close the block."""
    run = max((len(m) for m in re.findall(r"`+", text)), default=0)
    return "`" * max(3, run + 1)


def _md_block(b) -> str:
    if isinstance(b, Heading):
        return "#" * b.level + " " + _md_text(b.text).replace("\n", " ")
    if isinstance(b, Paragraph):
        return _md_lead(_inline_md(b.content))
    if isinstance(b, BulletList):
        return "\n".join("- " + _md_lead(_inline_md(i)) for i in b.items)
    if isinstance(b, Table):
        lines = ["| " + " | ".join(_md(h) for h in b.head) + " |",
                 "|" + "|".join("---" for _ in b.head) + "|"]
        lines += ["| " + " | ".join(_md(_cell(x)[0]) for x in row) + " |" for row in b.rows]
        return "\n".join(lines)
    if isinstance(b, Code):
        fence = _md_fence(b.text)
        return f"{fence}\n{b.text}\n{fence}"
    if isinstance(b, Figure):
        return f"![{_md(b.caption)}]({quote(b.path)})"
    if isinstance(b, Alert):
        return f"> **Warning:** {_md_text(b.text)}"
    if isinstance(b, Footer):
        return f"---\n{_md_lead(_md_text(b.text))}"
    raise TypeError(f"not a Markdown report block: {type(b).__name__}")


def to_markdown(blocks: Sequence) -> str:
    """The blocks as Markdown (CommonMark), separated by blank lines.

    Text cannot make Markdown or HTML of its own: ``&`` and ``<`` become entities, the
    characters of Markdown syntax are backslash-escaped, code spans and fences are longer
    than any backtick run inside.
    """
    return "\n\n".join(_md_block(b) for b in blocks if _shown(b, "md")) + "\n"

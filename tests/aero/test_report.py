"""The identification report (report.html, report.md, figures/) on a small synthetic run."""

from __future__ import annotations

import base64
import re
import warnings

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("matplotlib")

from simplexspline.aero.identify import IdentificationSettings, identify
from simplexspline.aero.selection.validation import PAPER_TABLE2
from simplexspline.aero.report.page import write_report
from simplexspline.aero.selection.search import SelectionSettings
from simplexspline.aero.modelling.structure import Structure

EVIL = ("test<script>alert('x')</script>&co`<img src=x onerror=alert(1)>`"
        "[c](javascript:alert(1))*x*_y_")


def _truth(alpha, beta, mach, de, da, dr, phat, qhat, rhat) -> dict:
    return {
        "CX": -0.02 + 0.15 * alpha + 0.6 * alpha ** 2 - 0.03 * mach,
        "CY": -0.9 * beta + 0.1 * dr,
        "CZ": -0.1 - 4.5 * alpha - 0.5 * de + 0.8 * mach * alpha,
        "Cl": -0.08 * beta + 0.05 * da - 0.4 * phat + 0.1 * rhat,
        "Cm": -0.01 - 0.6 * alpha - 1.2 * de - 8.0 * qhat + 0.5 * alpha ** 2,
        "Cn": 0.12 * beta - 0.06 * dr - 0.3 * rhat,
    }


def _synthetic(n_maneuvers: int = 10, n: int = 500, seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    frames = []
    for m in range(n_maneuvers):
        t = np.arange(n) * 0.02
        w = rng.uniform(0.5, 2.0, size=6)
        ph = rng.uniform(0, 2 * np.pi, size=6)
        alpha = 0.08 + 0.06 * np.sin(w[0] * t + ph[0]) + 0.02 * m / n_maneuvers
        beta = 0.03 * np.sin(w[1] * t + ph[1])
        mach = 0.35 + 0.04 * m + 0.01 * np.sin(0.3 * t)
        de = -0.03 + 0.05 * np.sin(w[2] * t + ph[2])
        da = 0.06 * np.sin(w[3] * t + ph[3])
        dr = 0.05 * np.sin(w[4] * t + ph[4])
        phat = 0.01 * np.sin(w[5] * t + ph[5])
        qhat = 0.004 * np.cos(w[0] * t + ph[0])
        rhat = 0.005 * np.cos(w[4] * t + ph[4])
        truth = _truth(alpha, beta, mach, de, da, dr, phat, qhat, rhat)
        cols = {"maneuver": np.full(n, m), "t": t,
                "maneuver_type": ["3211-elevator" if m % 2 else "sum-of-sines"] * n,
                "alpha": alpha, "beta": beta, "mach": mach, "tas": 340.0 * mach,
                "de": de, "da": da, "dr": dr, "phat": phat, "qhat": qhat, "rhat": rhat,
                "p": phat * 2 * 200 / 9.0, "q": qhat * 200 / 3.5, "r": rhat * 2 * 200 / 9.0}
        for c, v in truth.items():
            cols[c] = v + rng.normal(0.0, 1e-3, n)
            cols[f"true_{c}"] = v
        frames.append(pd.DataFrame(cols))
    return pd.concat(frames, ignore_index=True)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    df = _synthetic()
    structures = {"CZ": Structure("CZ", ("alpha", "de", "mach"), 2, 1),
                  "Cm": Structure("Cm", ("alpha", "qhat", "de"), 2, 1)}
    settings = IdentificationSettings(
        coefficients=("CZ", "Cm"), structures=structures, select=True,
        selection=SelectionSettings(max_rounds=1, moves=("degree",), max_samples=3000))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = identify(df, {"aircraft": EVIL, "note": "a < b & c > d"}, settings=settings)
    outdir = tmp_path_factory.mktemp("report") / "nested" / "out"
    lines = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        path = write_report(res, outdir, progress=lines.append)
    return res, outdir, path, lines


def test_files_written(report):
    _res, outdir, path, lines = report
    assert path == outdir / "report.html"
    assert path.is_file() and (outdir / "report.md").is_file()
    pngs = sorted((outdir / "figures").glob("*.png"))
    assert len(pngs) >= 10
    for p in pngs:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert lines and all(isinstance(x, str) for x in lines)


def test_html_self_contained(report):
    _, _, path, _ = report
    text = path.read_text(encoding="utf-8")
    srcs = re.findall(r"""<img\b[^>]*\bsrc\s*=\s*["']?([^"' >]*)""", text,
                      flags=re.IGNORECASE)
    assert srcs and all(s.startswith("data:image/png;base64,") for s in srcs)
    assert "<link" not in text.lower() and "<script" not in text.lower()
    assert "href=\"http" not in text and "@import" not in text
    first = re.search(r"data:image/png;base64,([A-Za-z0-9+/=]+)", text).group(1)
    assert base64.b64decode(first)[:4] == b"\x89PNG"


def test_html_contains_table_numbers(report):
    res, _, path, _ = report
    text = path.read_text(encoding="utf-8")
    for c, r in res.results.items():
        v = r.validation
        assert f"{100 * v['rrms']:.2f} %" in text
        assert f"{v['rms']:.3e}" in text
        assert f"{v['r2']:.4f}" in text
        assert f"{v['rms_true']:.3e}" in text and f"{v['noise_rms']:.3e}" in text
        assert f"{100 * PAPER_TABLE2[c]:.2f} %" in text


def test_derivative_table_has_the_jackknife_standard_errors(report):
    res, _, path, _ = report
    md = (path.parent / "report.md").read_text(encoding="utf-8")
    assert "standard error" in md and "jackknife" in md
    # the derivative figures shade the refits' spread
    assert "shaded: +- 2 jackknife standard errors" in md
    se = res.derivatives.loc["Cm_alpha", "standard_error"]
    row = next(line for line in md.splitlines() if "Cm\\_alpha" in line or "Cm_alpha" in line)
    assert f"{se:.2g}" in row, row


def test_coefficient_sections(report):
    res, _, path, _ = report
    text = path.read_text(encoding="utf-8")
    md = (path.parent / "report.md").read_text(encoding="utf-8")
    for c, r in res.results.items():
        assert f'id="coef-{c}"' in text
        label = r.structure.label()
        assert label in text and label.replace("_", "\\_").replace("*", "\\*") in md
        for fig in ("slices", "validation", "diagnostics", "selection"):
            assert f"figures/{c}_{fig}.png" in md
        # the triangulation projected on two scheduling variables, where there are two
        assert (f"figures/{c}_triangulation.png" in md) == (len(r.model.schedule) >= 2)
        # every tried structure of the selection history is listed
        for t in r.history:
            assert t.structure.label() in text
    assert "data_projections.png" in md and "maneuver_0.png" in md


def test_escaping(report):
    _, _, path, _ = report
    text = path.read_text(encoding="utf-8")
    md = (path.parent / "report.md").read_text(encoding="utf-8")
    assert "<script" not in text and "alert(" in text
    assert "test&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;&amp;co" in text
    assert "a &lt; b &amp; c &gt; d" in text
    assert "<script" not in md and "&lt;script" in md


def test_markdown_figures_exist(report):
    _, outdir, _, _ = report
    md = (outdir / "report.md").read_text(encoding="utf-8")
    refs = re.findall(r"\]\((figures/[^)]+\.png)\)", md)
    assert len(refs) >= 10
    for ref in refs:
        assert (outdir / ref).is_file(), ref


@pytest.mark.parametrize("workers", [1, 2])
def test_render_jobs_in_order(workers):
    from simplexspline.aero.report.page import _render

    lines = []
    jobs = [(f"job {i}", lambda i=i: i * i) for i in range(5)]
    assert _render(jobs, workers, lines.append) == [0, 1, 4, 9, 16]
    assert len(lines) == 5


@pytest.mark.parametrize("workers", [1, 2])
def test_figures_are_made_with_the_report_settings_and_leave_the_callers(workers):
    """Every job runs with render.RC (titles at a fixed height: no tick-label measuring),
    in a worker or in this process; the caller's matplotlib settings stay as they were."""
    import matplotlib

    from simplexspline.aero.report.page import _render
    from simplexspline.aero.report.render import RC

    before = dict(matplotlib.rcParams)
    jobs = [(f"job {i}", lambda: {k: matplotlib.rcParams[k] for k in RC}) for i in range(3)]
    assert _render(jobs, workers, lambda _line: None) == [RC] * 3
    assert dict(matplotlib.rcParams) == before


def test_projected_edges_unique():
    from simplexspline.aero.report.figures import projected_edges

    # two triangles sharing an edge: 5 distinct edges
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    seg = projected_edges(pts, np.array([[0, 1, 2], [0, 2, 3]]))
    assert seg.shape == (5, 2, 2)
    # a tetrahedron projected on (x, y): vertex 3 falls on vertex 0, leaving 3 segments
    pts3 = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    seg3 = projected_edges(pts3[:, :2], np.array([[0, 1, 2, 3]]))
    assert len(seg3) == 3 and np.all(np.any(seg3[:, 0] != seg3[:, 1], axis=1))


def test_markdown_report_renders_no_markup_from_data(report):
    """report.md through a CommonMark renderer (raw HTML allowed, as GitHub's is): data such
    as a hostile aircraft name yields no element, link or image of its own (issue 18, 6)."""
    markdown_it = pytest.importorskip("markdown_it")
    _, outdir, _, _ = report
    html = markdown_it.MarkdownIt("commonmark").render(
        (outdir / "report.md").read_text(encoding="utf-8"))
    assert "<script" not in html and "javascript:" not in html.replace("javascript:alert", "")
    assert not re.search(r"<a\s", html)
    imgs = re.findall(r"<img\s[^>]*>", html)
    assert imgs and all(re.search(r'src="figures/[^"]+\.png"', tag) for tag in imgs)
    assert "<em>" not in html.split("<h2>")[0]                 # no *x* / _y_ emphasis
    title = re.search(r"<h1>(.*?)</h1>", html).group(1)
    assert "&lt;img src=x onerror=alert(1)&gt;" in title and "[c](javascript:alert(1))" in title


# ---------------------------------------------------------------------------- document model
HOSTILE = [EVIL, "# heading", "- item", "1. item", "> quote", "---", "    indented code",
           "a\n# heading on a new line", "x\r\n---\r\ny", "<b>bold</b> & &amp;", "`` ` ``",
           "![img](x.png)", "<https://example.com>", "line\u2028# sep", "| a | b |",
           "\"quoted\" 'single'", "=====", "+ plus", "2) item", "~~~"]


def _blocks(text: str) -> list:
    from simplexspline.aero.report import document as d

    return [d.Heading(1, text), d.Heading(2, text, anchor=text),
            d.Paragraph(text), d.Paragraph([text, " ", d.Emph(text), " ", d.Strong(text), " ",
                         d.CodeSpan(text)]),
            d.BulletList([text, [text, d.CodeSpan(text)]]),
            d.Table([text, "b"], [[text, (text, "good")]], left=(0,), classes=["acc"]),
            d.Code(text), d.Code(text, summary=text), d.Alert(text),
            d.Nav([(text, text)]), d.Figure(text, text, b"\x89PNG"), d.Footer(text)]


def _html_tags(page: str) -> list:
    from html.parser import HTMLParser

    tags = []

    class Collect(HTMLParser):
        def handle_starttag(self, tag, attrs):
            tags.append((tag, dict(attrs)))

    Collect().feed(page)
    return tags


@pytest.mark.parametrize("text", HOSTILE)
def test_document_html_escapes_data(text):
    """Every block's text is data in HTML: the page has exactly the elements of its blocks,
    and the text comes back unchanged (attribute values included)."""
    from simplexspline.aero.report.document import to_html

    page = to_html(_blocks(text), title=text)
    tags = [t for t, _ in _html_tags(page)]
    assert tags == ["html", "head", "meta", "title", "style", "body", "h1", "h2", "p", "p",
                    "em", "strong", "code", "ul", "li", "li", "code", "table", "thead", "tr",
                    "th", "th", "tbody", "tr", "td", "td", "pre", "details", "summary", "pre",
                    "div", "nav", "a", "figure", "img", "figcaption", "hr", "p", "small"]
    attrs = dict(_html_tags(page))
    assert attrs["h2"]["id"] == text and attrs["a"]["href"] == "#" + text
    assert attrs["img"]["alt"] == text and attrs["img"]["src"].startswith("data:image/png;")
    import html as html_module
    assert html_module.unescape(page).count(text) >= 10


@pytest.mark.parametrize("text", HOSTILE)
def test_document_markdown_escapes_data(text):
    """Every block's text is data in Markdown: rendered by a CommonMark renderer, the
    document has exactly the elements of its blocks (no heading, list, quote, rule, code,
    link, image, emphasis or raw HTML from data), and its words come back as text."""
    markdown_it = pytest.importorskip("markdown_it")
    from simplexspline.aero.report.document import to_markdown

    page = markdown_it.MarkdownIt("commonmark").render(to_markdown(_blocks(text)))
    tags = [t for t, _ in _html_tags(page)]
    # commonmark has no tables: the table is one paragraph of text
    assert tags == ["h1", "h2", "p", "p", "em", "strong", "code", "ul", "li", "li", "code",
                    "p", "pre", "code", "pre", "code", "blockquote", "p", "strong", "p", "img",
                    "hr", "p"]
    images = [a for t, a in _html_tags(page) if t == "img"]
    from urllib.parse import unquote
    assert len(images) == 1 and unquote(images[0]["src"]) == f"figures/{text}.png"
    from html import unescape
    words = [w for w in re.split(r"\s+", text) if w]
    plain = unescape(re.sub(r"<[^>]+>", " ", page))
    assert all(w in plain for w in words)


def test_document_code_fence_outlasts_backticks():
    """A Markdown code block or span is closed only by its own fence, whatever backtick runs
    the text holds."""
    markdown_it = pytest.importorskip("markdown_it")
    from simplexspline.aero.report.document import Code, CodeSpan, Paragraph, to_markdown

    text = "a\n```\n<b>x</b>\n````\nb"
    md = to_markdown([Code(text), Paragraph(["x ", CodeSpan("``` `` `")])])
    assert md.startswith("`````\n" + text + "\n`````\n")
    page = markdown_it.MarkdownIt("commonmark").render(md)
    assert "<b>" not in page and page.count("<pre>") == 1
    assert "<code>``` `` `</code>" in page


def test_document_only_and_unknown_blocks():
    """Blocks marked html or md appear in that format alone; anything else is refused."""
    from simplexspline.aero.report.document import Nav, Paragraph, to_html, to_markdown

    blocks = [Paragraph("both"), Paragraph("web", only="html"), Paragraph("text", only="md"),
              Nav([("a", "link")])]
    html_page, md = to_html(blocks, title="t"), to_markdown(blocks)
    assert "both" in html_page and "web" in html_page and "text" not in html_page
    assert md == "both\n\ntext\n"
    with pytest.raises(TypeError, match="not a report block: str"):
        to_html(["<p>raw</p>"], title="t")
    with pytest.raises(TypeError, match="not a Markdown report block: str"):
        to_markdown(["raw"])

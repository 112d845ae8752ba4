"""Self-contained HTML reports (figures embedded, numbered and captioned) and a PDF of the same content."""

from __future__ import annotations

import contextlib
import datetime as dt
import html
import io
import json
import logging
import re
import textwrap
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Sequence

from pencli import __version__
from pencli.io.atomic import atomic_group

PDF_TEXT_COLUMNS = 110
"""Characters per line of a PDF text page in its monospaced 6.5 pt type on A4: longer lines wrap. [–]"""
PDF_TEXT_LINES = 120
"""Lines on one PDF text page; a longer section continues on the next page. [–]"""
A4_IN = (8.27, 11.69)
"""A4 portrait, width and height. [in]"""
PDF_TEXT_PT = 6.5
"""Type size of a PDF text page. [pt]"""
PDF_TEXT_TOP, PDF_TEXT_LEFT = 0.965, 0.05
"""Where a PDF text page's first line's baseline starts, as fractions of the page's height and width. [–]"""
PDF_LINE_PITCH_PT = (PDF_TEXT_TOP - 0.01) * A4_IN[1] * 72 / PDF_TEXT_LINES
"""Baseline to baseline on a PDF text page: its :data:`PDF_TEXT_LINES` lines fill the page. [pt]"""


@dataclass(frozen=True)
class Figure:
    """A figure drawn for a report: its SVG (vector, text kept as text), the matplotlib figure kept for the PDF's
    vector page (None once the report is written), and the sentence that states its answer."""

    svg: str
    caption: str
    paper: str = ""
    """The paper's figure it reproduces (``Fig. 13``), else empty."""
    figure: Any = None


@dataclass
class Section:
    """A titled part of a report: text, tables and figures, in that order."""

    title: str
    text: str = ""
    tables: list[tuple[str, list[str], list[list[Any]]]] = field(default_factory=list)
    """(caption, header with units, rows)."""
    figures: list[Figure] = field(default_factory=list)
    """Figures with their captions, drawn as SVG when added; the matplotlib figure stays open until the report's
    PDF is written (:func:`close_figures`)."""
    provenance: dict = field(default_factory=dict)

    def add_figure(self, fig, caption: str, paper: str = "") -> None:
        """Draw a matplotlib Figure as SVG and keep it, with its caption, for the HTML and the PDF (pyplot lets go
        of it: a long report holds no figures open in pyplot)."""
        import matplotlib
        import matplotlib.pyplot as plt

        buf = io.StringIO()
        with matplotlib.rc_context({"svg.fonttype": "none"}):  # text stays text: searchable, sharp at any size
            fig.savefig(buf, format="svg")
        plt.close(fig)  # the Figure object still draws (its canvas stays) for the PDF page
        fig.set_layout_engine("none")  # the layout the SVG drew is kept for the PDF: laid out once, not twice
        self.figures.append(Figure(buf.getvalue(), caption, paper, fig))


def close_figures(sections: Sequence[Section]) -> None:
    """Let go of the figures the sections hold for their PDF (their SVG is kept)."""
    for s in sections:
        s.figures[:] = [Figure(f.svg, f.caption, f.paper) for f in s.figures]


CSS = """
html { -webkit-text-size-adjust: 100%; }
body { font-family: system-ui, sans-serif; margin: 2em auto; padding: 0 1em; max-width: 1100px; color: #222;
       line-height: 1.45; text-align: left; }
h1 { border-bottom: 2px solid #444; } h2 { margin-top: 2em; border-bottom: 1px solid #aaa; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
caption { text-align: left; font-weight: 600; padding: 0.3em 0; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: right; } th { background: #eee; }
td:first-child, th:first-child { text-align: left; }
figure { margin: 1.5em 0; }
figure svg { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 0.92em; margin-top: 0.3em; }
pre { background: #f6f6f6; padding: 0.6em; font-size: 0.8em; overflow-x: auto; white-space: pre-wrap; }
"""


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return html.escape("" if value is None else str(value))


def numbered(sections: Sequence[Section]) -> list[tuple[Section, list[tuple[int, Figure]]]]:
    """Each section with its figures numbered through the report (1, 2, …)."""
    out, n = [], 0
    for s in sections:
        items = []
        for f in s.figures:
            n += 1
            items.append((n, f))
        out.append((s, items))
    return out


def _page_head(title: str) -> str:
    """The start of a pen HTML page up to its heading: language, viewport, title, style."""
    return (f"<!doctype html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(title)}</title><style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>")


def _stamp() -> str:
    """Which pen wrote a page, and when."""
    return f"pen {__version__}, {dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M} UTC"


def figure_label(number: int, figure: Figure) -> str:
    """``Figure 3 (paper Fig. 13).`` or ``Figure 3.``"""
    return f"Figure {number}" + (f" (paper {figure.paper})" if figure.paper else "") + "."


def render_html(title: str, sections: Sequence[Section]) -> str:
    """The report as one HTML document with every figure inlined, numbered and captioned."""
    parts = [_page_head(title), f"<p>{_stamp()}</p>"]
    for s, items in numbered(sections):
        parts.append(f"<h2>{html.escape(s.title)}</h2>")
        if s.text:
            parts.append(f"<p>{html.escape(s.text)}</p>")
        for caption, header, rows in s.tables:
            parts.append(f"<table><caption>{html.escape(caption)}</caption><tr>"
                         + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>")
            parts.extend("<tr>" + "".join(f"<td>{_cell(v)}</td>" for v in row) + "</tr>" for row in rows)
            parts.append("</table>")
        for number, f in items:
            label = figure_label(number, f)
            parts.append(f"<figure id='figure-{number}' role='figure' aria-label='{html.escape(label)}'>"
                         f"{_inline_svg(f.svg, label + ' ' + f.caption)}"
                         f"<figcaption><b>{html.escape(label)}</b> {html.escape(f.caption)}</figcaption></figure>")
        if s.provenance:
            parts.append("<details><summary>provenance</summary><pre>"
                         + html.escape(json.dumps(s.provenance, indent=2, default=str)) + "</pre></details>")
    parts.append("</body></html>")
    return "\n".join(parts)


def _inline_svg(svg: str, title: str) -> str:
    """An SVG document as an element of the page: without its XML prologue, scaled to the page's width, titled
    for screen readers."""
    start = svg.index("<svg")
    body = svg[start:]
    body = body.replace("<svg ", f"<svg role='img' aria-label='{html.escape(title)}' ", 1)
    return re.sub(r'(<svg[^>]*?) width="[^"]*" height="[^"]*"', r"\1", body, count=1)


def _text_lines(s: Section) -> list[str]:
    """A section's text, tables and provenance as lines of at most :data:`PDF_TEXT_COLUMNS` characters."""
    lines = [s.title, "", *([*textwrap.wrap(s.text, PDF_TEXT_COLUMNS), ""] if s.text else [])]
    for caption, header, rows in s.tables:
        widths = [max(len(str(h)), *(len(_cell(r[i])) for r in rows)) if rows else len(str(h))
                  for i, h in enumerate(header)]
        lines.append(caption)
        lines.append("  ".join(str(h).ljust(w) for h, w in zip(header, widths)))
        lines.extend("  ".join(html.unescape(_cell(v)).ljust(w) for v, w in zip(r, widths)) for r in rows)
        lines.append("")
    if s.provenance:
        lines.extend(["provenance:", *json.dumps(s.provenance, indent=1, default=str).splitlines()])
    out = []
    for line in lines:
        out.extend(textwrap.wrap(line, PDF_TEXT_COLUMNS, subsequent_indent="    ", drop_whitespace=False,
                                 replace_whitespace=False) or [""])
    return out


def _in_core_font(ch: str) -> bool:
    """Whether a PDF's built-in Courier can show ``ch`` (its encoding is Windows-1252)."""
    try:
        ch.encode("cp1252")
    except UnicodeEncodeError:
        return False
    return True


@contextlib.contextmanager
def _quiet_font_matching() -> Iterator[None]:
    """matplotlib logs each weight it substitutes; a text page's built-in Courier has one weight (medium) and its
    mathtext cells another, both as meant."""
    logger = logging.getLogger("matplotlib.font_manager")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def _text_page(plt, title: str, lines: Sequence[str]):
    """An A4 page of monospaced lines, to be saved with ``pdf.use14corefonts``: the PDF's built-in Courier
    needs no glyphs embedded (a page of provenance tables is written in a twentieth of the time an embedded
    font takes), and each character it cannot show (η, μ, ρ, θ) is set in the grid's cell as mathtext, which
    the PDF embeds."""
    page = plt.figure(figsize=A4_IN)
    page.suptitle(title, fontsize=9, y=0.995)
    pitch = PDF_LINE_PITCH_PT / 72 / A4_IN[1]
    advance = 0.6 * PDF_TEXT_PT / 72 / A4_IN[0]  # Courier: every character 0.6 em wide
    for k, line in enumerate(lines):
        y = PDF_TEXT_TOP - k * pitch
        core = "".join(ch if _in_core_font(ch) else " " for ch in line)
        if core.strip():
            page.text(PDF_TEXT_LEFT, y, core, va="baseline", ha="left", family="monospace", fontsize=PDF_TEXT_PT)
        for column, ch in enumerate(line):
            if not _in_core_font(ch):
                page.text(PDF_TEXT_LEFT + column * advance, y, f"$\\mathrm{{{ch}}}$", va="baseline", ha="left",
                          fontsize=PDF_TEXT_PT)
    return page


def render_pdf(title: str, sections: Sequence[Section], path: Path) -> None:
    """The same content as a PDF of A4 pages: a text page per section (tables, provenance; long lines wrap, long
    sections continue), then each figure on a page of its own with its number and caption."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    with PdfPages(path) as pdf:
        for s, items in numbered(sections):
            lines = _text_lines(s) + [""] + [line for n, f in items for line in textwrap.wrap(
                f"{figure_label(n, f)} {f.caption}", PDF_TEXT_COLUMNS, subsequent_indent="    ")]
            for start in range(0, len(lines), PDF_TEXT_LINES):
                page = _text_page(plt, title, lines[start:start + PDF_TEXT_LINES])
                with matplotlib.rc_context({"pdf.use14corefonts": True}), _quiet_font_matching():
                    pdf.savefig(page)
                plt.close(page)
            for number, f in items:  # each figure a vector page of its own size, its label in the corner
                if f.figure is None:
                    raise ValueError("a report's figures were closed before its PDF was written")
                mark = f.figure.text(0.995, 0.003, figure_label(number, f), ha="right", va="bottom", fontsize=6,
                                     color="0.45")
                pdf.savefig(f.figure)
                mark.remove()


def write_index(title: str, entries: Sequence[tuple[str, str, Path, str]], path: Path) -> Path:
    """An index page linking every report of ``pen report --all``: (group, title, path relative to the index,
    one line about it) per report, grouped in the order given."""
    from pencli.io.atomic import write_atomic

    groups: dict[str, list] = {}
    for group, name, relative, note in entries:
        groups.setdefault(group, []).append((name, relative, note))
    parts = [_page_head(title),
             f"<p>{_stamp()}; {len(entries)} reports (each with a PDF of the same beside it when written).</p>"]
    for group, items in groups.items():
        parts.append(f"<h2>{html.escape(group)} ({len(items)})</h2><ul>")
        parts.extend(f"<li><a href='{html.escape(relative.as_posix())}'>{html.escape(name)}</a>"
                     + (f" — {html.escape(note)}" if note else "") + "</li>" for name, relative, note in items)
        parts.append("</ul>")
    parts.append("</body></html>")
    write_atomic(path, lambda tmp: tmp.write_text("\n".join(parts), encoding="utf-8"))
    return path


def write_report(title: str, sections: Sequence[Section], html_path: str | Path, pdf: bool = True) -> list[Path]:
    """Write the HTML (and the PDF beside it): both appear, or neither changes."""
    html_path = Path(html_path)
    targets = [html_path, html_path.with_suffix(".pdf")] if pdf else [html_path]
    try:
        with atomic_group(targets) as temps:
            temps[0].write_text(render_html(title, sections), encoding="utf-8")
            if pdf:
                render_pdf(title, sections, temps[1])
    finally:
        close_figures(sections)
    return targets

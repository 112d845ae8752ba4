"""Self-contained HTML reports (figures embedded) and a PDF of the same content."""

from __future__ import annotations

import base64
import datetime as dt
import html
import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from pencli import __version__
from pencli.io.atomic import atomic_group


@dataclass
class Section:
    """A titled part of a report: text, tables and figures, in that order."""

    title: str
    text: str = ""
    tables: list[tuple[str, list[str], list[list[Any]]]] = field(default_factory=list)
    """(caption, header with units, rows)."""
    images: list[bytes] = field(default_factory=list)
    """Figures as PNG bytes (drawn and closed as they are added, so a long report holds no open figures)."""
    provenance: dict = field(default_factory=dict)

    def add_figure(self, fig) -> None:
        """Render a matplotlib Figure to PNG and close it."""
        import matplotlib.pyplot as plt

        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=100)
        plt.close(fig)
        self.images.append(buf.getvalue())


CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
h1 { border-bottom: 2px solid #444; } h2 { margin-top: 2em; border-bottom: 1px solid #aaa; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: right; } th { background: #eee; }
td:first-child, th:first-child { text-align: left; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.5em 0; }
pre { background: #f6f6f6; padding: 0.6em; font-size: 0.8em; overflow-x: auto; }
"""


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return html.escape("" if value is None else str(value))


def render_html(title: str, sections: Sequence[Section]) -> str:
    """The report as one HTML document with every figure inlined."""
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
             f"<style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>",
             f"<p>pen {__version__}, {dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M} UTC</p>"]
    for s in sections:
        parts.append(f"<h2>{html.escape(s.title)}</h2>")
        if s.text:
            parts.append(f"<p>{html.escape(s.text)}</p>")
        for caption, header, rows in s.tables:
            parts.append(f"<table><caption>{html.escape(caption)}</caption><tr>"
                         + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>")
            parts.extend("<tr>" + "".join(f"<td>{_cell(v)}</td>" for v in row) + "</tr>" for row in rows)
            parts.append("</table>")
        for image in s.images:
            parts.append(f"<img alt='{html.escape(s.title)}' src='data:image/png;base64,"
                         f"{base64.b64encode(image).decode()}'>")
        if s.provenance:
            parts.append("<details><summary>provenance</summary><pre>"
                         + html.escape(json.dumps(s.provenance, indent=2, default=str)) + "</pre></details>")
    parts.append("</body></html>")
    return "\n".join(parts)


def render_pdf(title: str, sections: Sequence[Section], path: Path) -> None:
    """The same content as a PDF: a text page per section (tables, provenance), then its figures."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    with PdfPages(path) as pdf:
        for s in sections:
            lines = [s.title, "", *([s.text, ""] if s.text else [])]
            for caption, header, rows in s.tables:
                widths = [max(len(str(h)), *(len(_cell(r[i])) for r in rows)) if rows else len(str(h))
                          for i, h in enumerate(header)]
                lines.append(caption)
                lines.append("  ".join(str(h).ljust(w) for h, w in zip(header, widths)))
                lines.extend("  ".join(_cell(v).ljust(w) for v, w in zip(r, widths)) for r in rows)
                lines.append("")
            if s.provenance:
                lines.extend(["provenance:", *json.dumps(s.provenance, indent=1, default=str).splitlines()[:40]])
            page = plt.figure(figsize=(8.27, 11.69))
            page.text(0.05, 0.97, "\n".join(lines[:90]), va="top", ha="left", family="monospace", fontsize=6.5)
            page.suptitle(f"{title}", fontsize=9, y=0.995)
            pdf.savefig(page)
            plt.close(page)
            for image in s.images:
                picture = plt.imread(io.BytesIO(image), format="png")
                page = plt.figure(figsize=(picture.shape[1] / 100, picture.shape[0] / 100))
                page.figimage(picture, 0, 0)
                pdf.savefig(page)
                plt.close(page)


def write_report(title: str, sections: Sequence[Section], html_path: str | Path, pdf: bool = True) -> list[Path]:
    """Write the HTML (and the PDF beside it): both appear, or neither changes."""
    html_path = Path(html_path)
    targets = [html_path, html_path.with_suffix(".pdf")] if pdf else [html_path]
    with atomic_group(targets) as temps:
        temps[0].write_text(render_html(title, sections), encoding="utf-8")
        if pdf:
            render_pdf(title, sections, temps[1])
    return targets

"""A self-contained HTML report: figures beside it, captions, numbers.

The page has no scripts and no network references: images are linked
relatively (``<img src="mosaic.png">``) and the style sheet is inline, so the
folder can be zipped, mailed or opened from a USB stick.
"""

from __future__ import annotations

import datetime as _dt
import html
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

__all__ = ["Figure", "Section", "Report", "provenance_text"]

_CSS = """
body { font: 15px/1.5 system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto;
       max-width: 1100px; padding: 1.5em 2em 4em; color: #1d1d1f; background: #fafafa; }
h1 { font-size: 1.8em; margin-bottom: 0.2em; }
h2 { margin-top: 2.2em; border-bottom: 1px solid #ddd; padding-bottom: 0.2em; }
.lead { color: #555; margin-top: 0; }
figure { margin: 1.2em 0 2em; background: #fff; border: 1px solid #e3e3e3; border-radius: 6px;
         padding: 0.8em; }
figure img { max-width: 100%; height: auto; display: block; margin: 0 auto; }
figcaption { color: #333; margin-top: 0.6em; font-size: 0.95em; }
figcaption b { color: #000; }
table { border-collapse: collapse; margin: 0.8em 0 1.5em; background: #fff; font-size: 0.92em; }
th, td { border: 1px solid #ddd; padding: 0.3em 0.7em; text-align: right; }
th { background: #f0f0f0; } td:first-child, th:first-child { text-align: left; }
pre { background: #fff; border: 1px solid #e3e3e3; padding: 0.8em; overflow-x: auto;
      font-size: 0.85em; }
details summary { cursor: pointer; color: #0a58ca; }
.footer { color: #777; font-size: 0.85em; margin-top: 3em; }
"""


@dataclass
class Figure:
    """One picture of the report: a file in the report's folder and its caption."""

    file: str
    title: str
    caption: str
    alt: str = ""


@dataclass
class Section:
    """A section: text, figures, tables of numbers and optional JSON details."""

    title: str
    text: str = ""
    figures: list[Figure] = field(default_factory=list)
    tables: list[tuple[str, Sequence[str], Sequence[Sequence[Any]]]] = field(default_factory=list)
    details: list[tuple[str, Any]] = field(default_factory=list)

    def figure(self, file: str, title: str, caption: str, *, alt: str = "") -> None:
        self.figures.append(Figure(file, title, caption, alt or title))

    def table(self, caption: str, header: Sequence[str], rows: Sequence[Sequence[Any]]) -> None:
        self.tables.append((caption, list(header), [list(r) for r in rows]))

    def detail(self, summary: str, data: Any) -> None:
        self.details.append((summary, data))


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return html.escape(str(v))


class Report:
    """Collects sections and writes ``report.html`` into a folder."""

    def __init__(self, title: str, *, lead: str = "") -> None:
        self.title = title
        self.lead = lead
        self.sections: list[Section] = []

    def section(self, title: str, text: str = "") -> Section:
        s = Section(title, text)
        self.sections.append(s)
        return s

    def figures(self) -> list[Figure]:
        return [f for s in self.sections for f in s.figures]

    def to_html(self) -> str:
        out = [
            "<!DOCTYPE html>",
            '<html lang="en"><head><meta charset="utf-8">',
            '<meta name="viewport" content="width=device-width, initial-scale=1">',
            f"<title>{html.escape(self.title)}</title>",
            f"<style>{_CSS}</style></head><body>",
            f"<h1>{html.escape(self.title)}</h1>",
        ]
        if self.lead:
            out.append(f'<p class="lead">{self.lead}</p>')
        if len(self.sections) > 2:
            out.append("<nav><ol>")
            for i, s in enumerate(self.sections):
                out.append(f'<li><a href="#s{i}">{html.escape(s.title)}</a></li>')
            out.append("</ol></nav>")
        for i, s in enumerate(self.sections):
            out.append(f'<h2 id="s{i}">{html.escape(s.title)}</h2>')
            if s.text:
                out.append(f"<p>{s.text}</p>")
            for caption, header, rows in s.tables:
                out.append("<table>")
                if caption:
                    out.append(f"<caption>{html.escape(caption)}</caption>")
                out.append("<tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in header) + "</tr>")
                for r in rows:
                    out.append("<tr>" + "".join(f"<td>{_cell(c)}</td>" for c in r) + "</tr>")
                out.append("</table>")
            for f in s.figures:
                out.append(
                    f'<figure><img src="{html.escape(f.file)}" alt="{html.escape(f.alt)}">'
                    f"<figcaption><b>{html.escape(f.title)}.</b> {f.caption}</figcaption></figure>"
                )
            for summary, data in s.details:
                text = data if isinstance(data, str) else json.dumps(data, indent=2, sort_keys=True)
                out.append(
                    f"<details><summary>{html.escape(summary)}</summary><pre>{html.escape(text)}</pre></details>"
                )
        stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
        out.append(f'<p class="footer">Made by cdbrdf on {stamp}.</p></body></html>')
        return "\n".join(out)

    def write(self, folder: str | PathLike[str], name: str = "report.html") -> Path:
        """Write the page into ``folder``; every figure file must already be there."""
        folder = Path(folder)
        missing = [f.file for f in self.figures() if not (folder / f.file).is_file()]
        if missing:
            raise FileNotFoundError(f"{folder}: report figures missing: {', '.join(missing)}")
        path = folder / name
        path.write_text(self.to_html(), encoding="utf-8")
        return path


def provenance_text(attrs: Mapping[str, Any]) -> str:
    """Pretty JSON of a table's provenance."""
    prov = attrs.get("provenance")
    if isinstance(prov, str):
        try:
            prov = json.loads(prov)
        except json.JSONDecodeError:
            return prov
    return json.dumps(prov, indent=2, sort_keys=True)

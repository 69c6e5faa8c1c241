"""A self-contained HTML report: figures beside it, captions, numbers.

The page has no scripts and no network references: images are linked
relatively (``<img src="mosaic.png">``) and the style sheet is inline, so the
folder can be zipped, mailed or opened from a USB stick.
"""

from __future__ import annotations

import datetime as _dt
import html
import json
import shutil
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from .fsutil import is_owned, mark_owned, sweep_stale, temp_sibling

__all__ = ["Figure", "Section", "Report", "output_folder", "check_output_folder", "provenance_text"]

_MARKER = ".cdbrdf-output"
_KIND = "output"

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
        stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
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


def check_output_folder(path: str | PathLike[str]) -> Path:
    """Refuse, before any work, an output folder that :func:`output_folder` would refuse.

    Cheap (no file is written), so that a command fails at once instead of
    after its computation. Returns the folder as a :class:`~pathlib.Path`.

    Raises
    ------
    FileExistsError
        When ``path`` is a file or a link, a non-empty folder cdbrdf did not
        make, or the current folder (or one that holds it).
    """
    dest = Path(path)
    if dest.exists() or dest.is_symlink():
        if dest.is_symlink() or not dest.is_dir():
            raise FileExistsError(f"{dest}: exists and is not a folder")
        if any(dest.iterdir()) and not _owned(dest):
            raise FileExistsError(
                f"{dest}: folder exists, is not empty and was not written by cdbrdf; "
                "choose another output folder"
            )
        cwd = Path.cwd().resolve()
        if cwd == dest.resolve() or dest.resolve() in cwd.parents:
            raise FileExistsError(
                f"{dest}: is the current folder (or holds it) and would be replaced whole; "
                "run from another folder or choose another output folder"
            )
    return dest


@contextmanager
def output_folder(path: str | PathLike[str]) -> Iterator[Path]:
    """Build an output folder beside ``path`` and swap it in only on success.

    Old results are never mixed with new ones: the new folder replaces a
    previous cdbrdf output folder whole. A folder that exists, is not empty
    and was not made by cdbrdf is refused (nothing of the user's is deleted),
    as is the current folder (:func:`check_output_folder`).
    On failure (or interrupt) the partial folder is removed and the old one
    left as it was; partial folders of killed runs (``.NAME.<pid>...partial``,
    with everything inside them) are removed by the next run.

    Yields
    ------
    pathlib.Path
        The partial folder to fill (marked as cdbrdf's own).
    """
    dest = check_output_folder(path)
    parent = dest.parent if str(dest.parent) else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    sweep_stale(dest)
    tmp = temp_sibling(dest, "partial")
    tmp.mkdir(mode=0o777)
    try:
        mark_owned(tmp, _KIND)
        (tmp / _MARKER).write_text("written by cdbrdf; the whole folder is replaced on the next run\n")
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if dest.exists():
        old = temp_sibling(dest, "old")
        dest.rename(old)
        tmp.rename(dest)
        shutil.rmtree(old, ignore_errors=True)
    else:
        tmp.rename(dest)


def _owned(folder: Path) -> bool:
    # folders of cdbrdf <= 0.1 carry only the old marker
    return is_owned(folder, _KIND) or (folder / _MARKER).is_file()


def provenance_text(attrs: Mapping[str, Any]) -> str:
    """Pretty JSON of a table's provenance."""
    prov = attrs.get("provenance")
    if isinstance(prov, str):
        try:
            prov = json.loads(prov)
        except json.JSONDecodeError:
            return prov
    return json.dumps(prov, indent=2, sort_keys=True)

"""A small, dependency-free HTML page builder for surfhap reports (figures are PNG files)."""

from __future__ import annotations

import html
from datetime import datetime, timezone
from pathlib import Path

__all__ = ["Page", "start_page"]

_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,sans-serif;margin:2rem auto;max-width:1150px;color:#222;padding:0 1rem}
h1{font-size:1.6rem}h2{font-size:1.25rem;margin-top:2.2rem;border-bottom:1px solid #ddd;padding-bottom:.2rem}
table{border-collapse:collapse;font-size:.9rem;margin:.6rem 0}td,th{border:1px solid #ccc;padding:.25rem .55rem;text-align:right}
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}img{max-width:100%;border:1px solid #eee;margin:.4rem 0}
.note{color:#555;font-size:.9rem}.bad{color:#b00}.ok{color:#070}code{background:#f5f5f5;padding:0 .2rem}
"""


class Page:
    """Collects sections, tables and images under ``title`` (and the ``command`` that made the
    page, if given); ``html()`` returns the page text."""

    def __init__(self, title: str, command: str = ""):
        self.title = title
        self._parts = [f"<p class=note>command: <code>{html.escape(command)}</code></p>"] if command else []

    def heading(self, text: str) -> None:
        self._parts.append(f"<h2>{html.escape(text)}</h2>")

    def paragraph(self, text: str, cls: str | None = None) -> None:
        attr = f' class="{cls}"' if cls else ""
        self._parts.append(f"<p{attr}>{html.escape(text)}</p>")

    def table(self, header: list[str], rows: list[list[object]]) -> None:
        head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
        body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
        self._parts.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")

    def figure(self, fig, folder, name: str, alt: str, *, dpi: int = 110) -> None:
        """Save ``fig`` as ``folder/name`` (a PNG) and show it here."""
        fig.savefig(Path(folder) / name, dpi=dpi)
        self._parts.append(f'<img src="{html.escape(name)}" alt="{html.escape(alt)}">')

    def write(self, path) -> Path:
        """Write the page to ``path``; returns it."""
        Path(path).write_text(self.html(), encoding="utf-8")
        return Path(path)

    def html(self) -> str:
        stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        return (f"<!doctype html><html lang=en><head><meta charset=utf-8><title>{html.escape(self.title)}</title>"
                f"<meta name=viewport content='width=device-width,initial-scale=1'><style>{_STYLE}</style></head><body>"
                f"<h1>{html.escape(self.title)}</h1><p class=note>made by surfhap, {stamp}</p>"
                + "\n".join(self._parts) + "</body></html>\n")


def start_page(out_dir: str | Path, title: str, command: str = "") -> tuple[Path, Page]:
    """The output folder ``out_dir`` (created) and a page titled ``title`` noting ``command``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return out, Page(title, command)

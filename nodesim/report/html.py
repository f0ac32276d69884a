"""A tiny HTML page builder: headings, paragraphs, tables and embedded PNG figures (no template engine).

Every text goes through :func:`html.escape`; figures (:class:`matplotlib.figure.Figure` built directly, so no
backend is chosen or switched) are saved as PNG into memory and embedded as ``data:image/png;base64`` URIs, so
the page is a single self-contained file.
"""

from __future__ import annotations

import base64
import html
import io
from dataclasses import dataclass, field

STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; font-size: 0.85em; margin: 0.6em 0; }
th, td { border: 1px solid #ccc; padding: 2px 8px; text-align: right; }
th { background: #f2f2f2; } td.text { text-align: left; }
figure { margin: 1em 0; } figcaption { font-size: 0.85em; color: #555; }
img { max-width: 100%; } .note { color: #666; font-style: italic; }
"""


def fig_png(fig, dpi: int = 100) -> bytes:
    """PNG bytes of a matplotlib figure at ``dpi``."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def _cell(v) -> str:
    if isinstance(v, float):
        text = "n/a" if v != v else f"{v:.4g}"
        return f"<td>{text}</td>"
    if isinstance(v, (int,)) and not isinstance(v, bool):
        return f"<td>{v}</td>"
    return f'<td class="text">{html.escape("n/a" if v is None else str(v))}</td>'


@dataclass
class Page:
    title: str
    parts: list = field(default_factory=list)
    n_images: int = 0

    def heading(self, text: str) -> None:
        self.parts.append(f"<h2>{html.escape(text)}</h2>")

    def para(self, text: str, note: bool = False) -> None:
        cls = ' class="note"' if note else ""
        self.parts.append(f"<p{cls}>{html.escape(text)}</p>")

    def table(self, header: list, rows: list[list]) -> None:
        head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
        body = "".join("<tr>" + "".join(_cell(v) for v in row) + "</tr>" for row in rows)
        self.parts.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")

    def image(self, png: bytes, caption: str) -> None:
        if not png:
            raise ValueError(f"empty image for {caption!r}")
        data = base64.b64encode(png).decode("ascii")
        alt = html.escape(caption, quote=True)
        self.parts.append(
            f'<figure><img src="data:image/png;base64,{data}" alt="{alt}"><figcaption>{html.escape(caption)}</figcaption></figure>'
        )
        self.n_images += 1

    def figure(self, fig, caption: str, dpi: int = 100) -> None:
        self.image(fig_png(fig, dpi), caption)

    def render(self) -> str:
        title = html.escape(self.title)
        body = "\n".join(self.parts)
        return (
            f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{title}</title>'
            f"<style>{STYLE}</style></head>\n<body><h1>{title}</h1>\n{body}\n</body></html>\n"
        )

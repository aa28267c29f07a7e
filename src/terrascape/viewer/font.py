"""A bitmap font for the viewer's HUD, generated at start from Pillow's default font.

Janković 2010 §2.6.4.3 puts GUI text on screen with a font texture (Irrlicht's ``fontlucida.png``);
this module makes the equivalent texture at run time so that no font file ships with the
package: every glyph of :data:`CHARSET` is drawn once with ``ImageFont.load_default`` into a
grid of equal cells (an *atlas*), and text becomes one textured quad per glyph
(:func:`layout_text`). Pure numpy + Pillow; the GL side is :mod:`terrascape.viewer.hud`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrascape._validate import check_int
from terrascape.errors import InvalidParameterError

# Printable ASCII plus the symbols the HUD and help panel use (degrees, ±, ∓, ×, ·, …).
CHARSET = "".join(chr(c) for c in range(32, 127)) + "°±∓×·…→↑↓←–—≤≥▶◀"
FALLBACK = "?"
# ASCII stand-ins for symbols the default font may lack (it draws an empty box for those).
SUBSTITUTES = {"∓": "-/+", "±": "+/-", "…": "...", "→": "->", "←": "<-", "↑": "^", "↓": "v",
               "–": "-", "—": "-", "×": "x", "·": ".", "°": " deg", "≤": "<=", "≥": ">=",
               "▶": ">", "◀": "<"}
_MISSING_PROBE = "\ue000"  # a private-use code point no font maps: its glyph is "missing"


@dataclass(frozen=True)
class BitmapFont:
    """A glyph atlas and its metrics.

    Attributes
    ----------
    atlas
        ``uint8 (H, W)`` coverage (0 transparent … 255 opaque), row 0 at the top.
    cell
        ``(cell_width, cell_height)`` of one atlas cell in pixels.
    columns
        Cells per atlas row.
    line_height
        Pixels from one baseline to the next.
    advances
        Horizontal advance of each glyph in pixels (``dict[str, float]``).
    index
        Atlas cell of each glyph (``dict[str, int]``).
    """

    atlas: np.ndarray
    cell: tuple[int, int]
    columns: int
    line_height: int
    advances: dict
    index: dict

    def glyph(self, ch: str) -> str:
        """``ch`` if the font has it, else the fallback glyph."""
        return ch if ch in self.index else FALLBACK

    def expand(self, text: str) -> str:
        """``text`` with characters the font lacks replaced by ASCII stand-ins (or ``?``)."""
        out = []
        for c in text:
            if c in self.index or c == "\t":
                out.append(c)
            else:
                sub = SUBSTITUTES.get(c, FALLBACK)
                out.append(sub if all(x in self.index for x in sub) else FALLBACK)
        return "".join(out)

    def cell_uv(self, ch: str) -> tuple[float, float, float, float]:
        """Texture rectangle ``(u0, v0, u1, v1)`` of a glyph; v grows downward (row 0 = top)."""
        k = self.index[self.glyph(ch)]
        cw, chh = self.cell
        h, w = self.atlas.shape
        col, row = k % self.columns, k // self.columns
        return (col * cw / w, row * chh / h, (col + 1) * cw / w, (row + 1) * chh / h)

    def text_width(self, text: str, tab: float | None = None) -> float:
        """Width of one line of text in pixels (``tab``: see :func:`layout_text`)."""
        pen = 0.0
        for c in self.expand(text):
            pen = _advance(self, pen, c, tab)
        return pen


def _advance(font: BitmapFont, pen: float, c: str, tab: float | None) -> float:
    if c == "\t":
        four = 4 * font.advances[" "]
        return max(pen + font.advances[" "], tab) if tab is not None else pen + four
    return pen + font.advances[font.glyph(c)]


def build_font(size: int = 14, charset: str = CHARSET) -> BitmapFont:
    """Render ``charset`` with Pillow's default font into an atlas.

    Parameters
    ----------
    size
        Font size in pixels (6…64). Pillow's built-in FreeType font is scalable; without
        FreeType Pillow falls back to its fixed bitmap font, whose size is ignored.
    charset
        Characters to include; :data:`FALLBACK` is always added.

    Returns
    -------
    BitmapFont
    """
    from PIL import Image, ImageDraw, ImageFont

    size = check_int(size, "font size (pixels)", minimum=6, maximum=64)
    if not isinstance(charset, str) or not charset:
        raise InvalidParameterError(f"charset must be a non-empty string, got {charset!r}")
    chars = list(dict.fromkeys(charset + FALLBACK))
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:  # pragma: no cover - Pillow < 10.1 has no sizeable default font
        font = ImageFont.load_default()
    if hasattr(font, "getmetrics"):
        ascent, descent = font.getmetrics()
    else:  # pragma: no cover - bitmap default font
        ascent, descent = font.getbbox("Ag")[3], 2
    cell_h = int(ascent + descent + 2)
    advances = {c: float(font.getlength(c)) for c in chars}
    # Small sizes of the default font have a space under 3 px: words would run together.
    advances[" "] = max(advances.get(" ", 0.0), 0.35 * size)
    # Cells are as wide as the widest glyph's ink or advance, so no glyph is cut off.
    ink_w = max(max(font.getbbox(c)[2] for c in chars), int(np.ceil(max(advances.values()))))
    cell_w = int(ink_w + 2)
    columns = 16
    # Glyphs drawn exactly like an unmapped code point are missing from the font.
    def bitmap(c: str) -> tuple:
        mask = font.getmask(c)
        return (mask.size, bytes(mask))

    missing = bitmap(_MISSING_PROBE) if _MISSING_PROBE not in chars else None
    chars = [c for c in chars if c in " " + FALLBACK or missing is None
             or bitmap(c) != missing]
    rows = -(-len(chars) // columns)
    image = Image.new("L", (columns * cell_w, rows * cell_h), 0)
    draw = ImageDraw.Draw(image)
    index = {}
    for k, c in enumerate(chars):
        col, row = k % columns, k // columns
        # One pixel of margin on every side keeps bilinear sampling from bleeding neighbours.
        draw.text((col * cell_w + 1, row * cell_h + 1), c, fill=255, font=font)
        index[c] = k
    return BitmapFont(
        atlas=np.asarray(image, dtype=np.uint8).copy(),
        cell=(cell_w, cell_h),
        columns=columns,
        line_height=cell_h,
        advances=advances,
        index=index,
    )


def layout_text(
    font: BitmapFont, lines: list[str] | tuple[str, ...], x: float, y: float, *,
    scale: float = 1.0, tab: float | None = None,
) -> np.ndarray:
    """Quads for lines of text whose top-left corner is at pixel ``(x, y)`` (y down).

    A ``"\\t"`` moves the pen to ``x + tab`` (unscaled pixels; at least one space further),
    which aligns a second column with the proportional font; without ``tab`` it is four
    spaces. Characters the font lacks are replaced (:meth:`BitmapFont.expand`).

    Returns
    -------
    numpy.ndarray
        float32 ``(6·n_glyphs, 4)``: two triangles per visible glyph, each vertex
        ``(px, py, u, v)`` in window pixels (y down) and atlas texture coordinates. Spaces
        advance the pen without emitting a quad.
    """
    if isinstance(lines, str):
        lines = lines.splitlines()
    cw, ch = font.cell[0] * scale, font.cell[1] * scale
    quads = []
    for i, line in enumerate(lines):
        pen = 0.0
        top = float(y) + i * font.line_height * scale
        for c in font.expand(str(line)):
            g = font.glyph(c) if c != "\t" else " "
            if g != " ":
                u0, v0, u1, v1 = font.cell_uv(g)
                x0, y0, x1, y1 = x + pen * scale, top, x + pen * scale + cw, top + ch
                quads += [
                    (x0, y0, u0, v0), (x1, y0, u1, v0), (x1, y1, u1, v1),
                    (x0, y0, u0, v0), (x1, y1, u1, v1), (x0, y1, u0, v1),
                ]  # fmt: skip
            pen = _advance(font, pen, c, tab)
    if not quads:
        return np.zeros((0, 4), np.float32)
    return np.asarray(quads, dtype=np.float32)


def text_block_size(font: BitmapFont, lines, *, scale: float = 1.0,
                    tab: float | None = None) -> tuple[float, float]:
    """``(width, height)`` in pixels of lines laid out by :func:`layout_text`."""
    if isinstance(lines, str):
        lines = lines.splitlines()
    if not lines:
        return (0.0, 0.0)
    width = max(font.text_width(str(line), tab) for line in lines) * scale
    return (width, len(lines) * font.line_height * scale)


__all__ = ["CHARSET", "FALLBACK", "SUBSTITUTES", "BitmapFont", "build_font", "layout_text",
           "text_block_size"]

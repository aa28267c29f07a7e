"""On-screen text for the viewer: panels of lines drawn as textured quads over the scene.

The glyph atlas comes from :func:`terrascape.viewer.font.build_font` (generated at start);
the program ``viewer/hud`` (``render/shaders/viewer/hud.glsl``, loaded like every program by
:func:`terrascape.render.shaders.load_program`) draws glyphs and panel backgrounds in window
pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrascape.errors import InvalidParameterError
from terrascape.render.shaders import load_program
from terrascape.viewer.font import BitmapFont, build_font, layout_text, text_block_size

PROGRAM = "viewer/hud"
PADDING = 6.0
#: Laid-out lines a HUD keeps (cleared when full).
LINE_CACHE = 512


@dataclass
class Panel:
    """Lines of text at a corner of the window.

    ``anchor`` is ``"top-left"``, ``"top-right"``, ``"bottom-left"``, ``"bottom-right"`` or
    ``"center"``; ``background`` is the RGBA of the panel behind the text (alpha 0: none).
    """

    lines: list[str]
    anchor: str = "top-left"
    color: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    background: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.45)


def column_tab(font: BitmapFont, lines) -> float | None:
    """Tab stop aligning the text after ``"\\t"`` in every line: the widest first column plus
    two spaces; ``None`` when no line has a tab."""
    firsts = [line.split("\t", 1)[0] for line in lines if "\t" in line]
    if not firsts:
        return None
    return max(font.text_width(f) for f in firsts) + 2 * font.advances[" "]


def panel_origin(size: tuple[float, float], viewport: tuple[int, int], anchor: str,
                 margin: float = 8.0) -> tuple[float, float]:
    """Top-left pixel of a ``size`` block placed at ``anchor`` of the viewport."""
    w, h = size
    vw, vh = viewport
    x = {"left": margin, "right": vw - w - margin}
    y = {"top": margin, "bottom": vh - h - margin}
    if anchor == "center":
        return ((vw - w) / 2.0, (vh - h) / 2.0)
    try:
        vert, horiz = anchor.split("-")
        return (x[horiz], y[vert])
    except (ValueError, KeyError):
        raise InvalidParameterError(
            f"anchor must be top-left, top-right, bottom-left, bottom-right or center, "
            f"got {anchor!r}"
        ) from None


class HudRenderer:
    """Draws :class:`Panel` lists with one font atlas texture and one dynamic vertex buffer."""

    def __init__(self, ctx, font: BitmapFont | None = None, *, font_size: int = 14) -> None:
        import moderngl

        self.ctx = ctx
        self.font = font or build_font(font_size)
        h, w = self.font.atlas.shape
        self._tex = ctx.texture((w, h), 1, self.font.atlas.tobytes())
        self._tex.filter = (moderngl.NEAREST, moderngl.NEAREST)  # crisp 1:1 glyph pixels
        self._prog = load_program(ctx, PROGRAM)  # cached per context: released with it
        self._capacity = 6 * 4 * 4 * 2048
        self._vbo = ctx.buffer(reserve=self._capacity, dynamic=True)
        self._vao = ctx.vertex_array(self._prog, [(self._vbo, "2f 2f", "in_pos", "in_uv")])
        self._lines: dict[tuple, np.ndarray] = {}

    def _upload(self, verts: np.ndarray) -> None:
        data = np.ascontiguousarray(verts, dtype=np.float32).tobytes()
        if len(data) > self._capacity:
            self._capacity = 2 * len(data)
            self._vao.release()
            self._vbo.release()
            self._vbo = self.ctx.buffer(reserve=self._capacity, dynamic=True)
            self._vao = self.ctx.vertex_array(
                self._prog, [(self._vbo, "2f 2f", "in_pos", "in_uv")]
            )
        self._vbo.write(data)

    def _line_quads(self, line: str, scale: float, tab: float | None) -> np.ndarray:
        """The quads of one line laid out at pixel (0, 0), float64, kept for the next
        frames: a HUD's lines mostly repeat from frame to frame (the frame rate's changes)."""
        key = (line, scale, tab)
        quads = self._lines.get(key)
        if quads is None:
            if len(self._lines) >= LINE_CACHE:
                self._lines.clear()
            quads = layout_text(self.font, [line], 0.0, 0.0, scale=scale,
                                tab=tab).astype(np.float64)
            self._lines[key] = quads
        return quads

    def _panel_quads(self, lines: list[str], x: float, y: float, scale: float,
                     tab: float | None) -> np.ndarray:
        """:func:`~terrascape.viewer.font.layout_text` of ``lines`` at ``(x, y)``, built
        from the kept lines (the same vertices)."""
        step = self.font.line_height * scale
        parts = []
        for i, line in enumerate(lines):
            quads = self._line_quads(str(line), scale, tab)
            if len(quads):
                placed = quads.copy()
                placed[:, 0] += x
                placed[:, 1] += float(y) + i * step
                parts.append(placed)
        if not parts:
            return np.zeros((0, 4), np.float32)
        return np.concatenate(parts).astype(np.float32)

    def draw(self, fbo, panels: list[Panel], *, scale: float = 1.0) -> int:
        """Draw ``panels`` over whatever ``fbo`` holds; returns the glyph quads drawn.

        Every panel's vertices go to the GPU in one upload before the draws: a software
        rasteriser that sees a buffer written while a draw of this frame still reads it
        finishes the whole frame first."""
        import moderngl

        # (first vertex, count, solid, colour) of each draw, over one vertex array
        draws: list[tuple[int, int, int, tuple]] = []
        parts: list[np.ndarray] = []
        at = 0
        glyphs = 0
        vw, vh = fbo.size
        for panel in panels:
            if not panel.lines:
                continue
            tab = column_tab(self.font, panel.lines)
            bw, bh = text_block_size(self.font, panel.lines, scale=scale, tab=tab)
            ox, oy = panel_origin((bw + 2 * PADDING, bh + 2 * PADDING), (vw, vh), panel.anchor)
            if panel.background[3] > 0:
                x0, y0, x1, y1 = ox, oy, ox + bw + 2 * PADDING, oy + bh + 2 * PADDING
                parts.append(np.array([(x0, y0, 0, 0), (x1, y0, 0, 0), (x1, y1, 0, 0),
                                       (x0, y0, 0, 0), (x1, y1, 0, 0), (x0, y1, 0, 0)],
                                      np.float32))
                draws.append((at, 6, 1, tuple(panel.background)))
                at += 6
            verts = self._panel_quads(panel.lines, ox + PADDING, oy + PADDING, scale, tab)
            if len(verts):
                parts.append(verts)
                draws.append((at, len(verts), 0, tuple(panel.color)))
                at += len(verts)
                glyphs += len(verts) // 6
        if not draws:
            return 0
        self._upload(np.concatenate(parts))
        ctx = self.ctx
        fbo.use()
        ctx.viewport = (0, 0, vw, vh)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self._prog["u_viewport"].value = (float(vw), float(vh))
        self._prog["u_atlas"].value = 0
        self._tex.use(location=0)
        try:
            for first, count, solid, color in draws:
                self._prog["u_solid"].value = solid
                self._prog["u_color"].value = color
                self._vao.render(moderngl.TRIANGLES, vertices=count, first=first)
        finally:
            ctx.disable(moderngl.BLEND)
        return glyphs

    def release(self) -> None:
        self._vao.release()
        self._vbo.release()
        self._tex.release()


__all__ = ["HudRenderer", "Panel", "column_tab", "panel_origin"]

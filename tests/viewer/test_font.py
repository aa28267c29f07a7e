"""The HUD's bitmap font: atlas generation (Pillow default font) and text layout."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.viewer.font import FALLBACK, build_font, layout_text, text_block_size
from terrascape.viewer.hud import panel_origin


@pytest.fixture(scope="module")
def font():
    return build_font(12)


def _cell(font, ch):
    k = font.index[ch]
    cw, chh = font.cell
    col, row = k % font.columns, k // font.columns
    return font.atlas[row * chh : (row + 1) * chh, col * cw : (col + 1) * cw]


def test_atlas_has_ink_for_glyphs_and_none_for_space(font):
    assert font.atlas.dtype == np.uint8
    for ch in "AZaz09°±":
        assert (_cell(font, ch) > 128).sum() >= 3, ch
    assert _cell(font, " ").max() == 0
    # different letters are different bitmaps
    assert not np.array_equal(_cell(font, "O"), _cell(font, "I"))
    # the one-pixel margin keeps neighbouring cells apart
    assert (font.atlas.reshape(-1, font.cell[1], font.atlas.shape[1])[:, 0, :] == 0).all()


def test_layout_quads_count_positions_and_uv(font):
    verts = layout_text(font, ["AB C", "x"], 10, 20)
    assert verts.shape == (4 * 6, 4)  # spaces emit no quad
    quads = verts.reshape(-1, 6, 4)
    lefts = quads[:, 0, 0]
    assert lefts[0] == 10 and lefts[1] == pytest.approx(10 + font.advances["A"])
    assert lefts[2] == pytest.approx(10 + font.advances["A"] + font.advances["B"]
                                     + font.advances[" "])
    # second line starts again at x and one line lower
    assert lefts[3] == 10
    assert quads[3, 0, 1] == pytest.approx(20 + font.line_height)
    # texture rectangle of "A" is its atlas cell
    u0, v0, u1, v1 = font.cell_uv("A")
    assert quads[0, 0, 2:].tolist() == pytest.approx([u0, v0])
    assert quads[0, 2, 2:].tolist() == pytest.approx([u1, v1])
    assert verts[:, 2].min() >= 0 and verts[:, 2].max() <= 1


def test_unknown_characters_use_the_fallback(font):
    assert font.glyph("\u4e2d") == FALLBACK
    a = layout_text(font, ["\u4e2d"], 0, 0)
    b = layout_text(font, [FALLBACK], 0, 0)
    np.testing.assert_array_equal(a, b)


def test_block_size_and_scale(font):
    w, h = text_block_size(font, ["abc", "a"])
    assert w == pytest.approx(font.text_width("abc"))
    assert h == 2 * font.line_height
    w2, h2 = text_block_size(font, ["abc", "a"], scale=2.0)
    assert (w2, h2) == pytest.approx((2 * w, 2 * h))
    assert text_block_size(font, []) == (0.0, 0.0)


def test_font_size_changes_metrics_and_is_validated():
    assert build_font(20).line_height > build_font(10).line_height
    with pytest.raises(InvalidParameterError, match="font size"):
        build_font(2)


def test_panel_origin_anchors():
    assert panel_origin((100, 50), (640, 480), "top-left") == (8.0, 8.0)
    assert panel_origin((100, 50), (640, 480), "bottom-right") == (532.0, 422.0)
    assert panel_origin((100, 50), (640, 480), "center") == (270.0, 215.0)
    with pytest.raises(InvalidParameterError, match="anchor"):
        panel_origin((1, 1), (10, 10), "middle")


def test_tabs_align_columns_and_missing_symbols_are_substituted(font):
    from terrascape.viewer.hud import column_tab

    lines = ["A\tx", "WWWW\ty"]
    tab = column_tab(font, lines)
    assert tab == pytest.approx(font.text_width("WWWW") + 2 * font.advances[" "])
    quads = layout_text(font, lines, 0, 0, tab=tab).reshape(-1, 6, 4)
    # the glyph after the tab starts at the same x on both lines
    x_after = [quads[1, 0, 0], quads[6, 0, 0]]
    assert x_after[0] == pytest.approx(tab) and x_after[1] == pytest.approx(tab)
    assert column_tab(font, ["no tab"]) is None
    # a symbol the font draws as an empty box is replaced by its ASCII stand-in
    assert "\ue000" not in font.index
    if "∓" not in font.index:
        assert font.expand("∓") == "-/+"
    assert font.expand("\ue001") == FALLBACK


@pytest.mark.gl
def test_hud_program_comes_from_the_shared_loader(gl_ctx):
    """The HUD's program is one of the renderer's (render/shaders/viewer/hud.glsl, cached
    per context), and it draws: white glyphs over a black framebuffer."""
    from terrascape.render.context import current
    from terrascape.render.shaders import available_programs, load_program
    from terrascape.viewer.hud import PROGRAM, HudRenderer, Panel

    assert PROGRAM in available_programs()
    with current(gl_ctx):
        hud = HudRenderer(gl_ctx, font_size=12)
        fbo = gl_ctx.simple_framebuffer((120, 40))
        try:
            assert hud._prog is load_program(gl_ctx, PROGRAM)
            fbo.clear(0.0, 0.0, 0.0, 1.0)
            assert hud.draw(fbo, [Panel(["HUD 42"], background=(0.0, 0.0, 0.0, 0.0))]) == 5
            img = np.frombuffer(fbo.read(components=3), np.uint8).reshape(40, 120, 3)
            assert (img.min(-1) > 200).sum() > 20
        finally:
            hud.release()
            fbo.release()
        assert load_program(gl_ctx, PROGRAM) is not None  # still usable after release


def test_every_symbol_the_viewer_writes_has_a_glyph_or_a_stand_in():
    # The HUD drew "error ? 3.0 px": "≤" was in a message but not in the atlas's charset.
    import ast
    from pathlib import Path

    import terrascape.viewer
    from terrascape.viewer.font import CHARSET, SUBSTITUTES

    missing = {}
    for path in Path(terrascape.viewer.__file__).parent.glob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                      if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                           ast.AsyncFunctionDef))
                      and node.body and isinstance(node.body[0], ast.Expr)
                      and isinstance(node.body[0].value, ast.Constant)}
        for node in ast.walk(tree):
            if (isinstance(node, ast.Constant) and isinstance(node.value, str)
                    and id(node) not in docstrings):
                for ch in node.value:
                    private_use = 0xE000 <= ord(ch) <= 0xF8FF  # the font's own probe
                    if (ord(ch) > 126 and not private_use and ch not in CHARSET
                            and ch not in SUBSTITUTES):
                        missing.setdefault(ch, path.name)
    assert not missing, f"characters without a glyph in the HUD's charset: {missing}"
    font = build_font(12)
    assert FALLBACK not in font.expand("error ≤ 3.0 px ▶ 10 min/s ◀")


@pytest.mark.gl
def test_hud_lays_out_kept_lines_as_layout_text_and_uploads_once(gl_ctx, monkeypatch):
    """The HUD keeps each line's quads between frames: a panel's vertices are exactly
    layout_text's (tabs, substituted characters, blank lines, a scale), and a frame of
    several panels goes to the GPU in one upload (a second write to a buffer that a draw of
    the frame still reads makes a software rasteriser finish the frame first); the same
    panels drawn again give the same pixels."""
    from terrascape.render.context import current
    from terrascape.viewer.hud import HudRenderer, Panel, column_tab

    lines = ["fps 12.5\t67 ms", "", "café ∓ ok", "\ttabbed", "triangles 249,472"]
    with current(gl_ctx):
        hud = HudRenderer(gl_ctx, font_size=12)
        fbo = gl_ctx.simple_framebuffer((320, 200))
        try:
            tab = column_tab(hud.font, lines)
            for scale, x, y in ((1.0, 14.0, 6.0), (1.5, 3.25, 100.5), (1.0, 14.0, 6.0)):
                want = layout_text(hud.font, lines, x, y, scale=scale, tab=tab)
                got = hud._panel_quads(lines, x, y, scale, tab)
                np.testing.assert_array_equal(got, want)
            uploads = []
            real = hud._upload
            monkeypatch.setattr(hud, "_upload", lambda v: (uploads.append(len(v)), real(v)))
            panels = [Panel(lines), Panel(["bottom"], anchor="bottom-right"),
                      Panel(["centre"], anchor="center", background=(0, 0, 0, 0))]
            frames = []
            for _ in range(2):
                fbo.clear(0.2, 0.3, 0.4, 1.0)
                hud.draw(fbo, panels)
                frames.append(np.frombuffer(fbo.read(components=3), np.uint8).copy())
            assert len(uploads) == 2  # one per frame
            np.testing.assert_array_equal(frames[0], frames[1])
            assert (frames[0].reshape(200, 320, 3).min(-1) > 200).sum() > 100
        finally:
            hud.release()
            fbo.release()

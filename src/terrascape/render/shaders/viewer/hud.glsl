// HUD: text glyph quads from the bitmap font atlas (terrascape.viewer.font) and solid
// background panels, in window pixels (origin top-left, y down) — the thesis's GUI text
// (Janković 2010 §2.6.4.3: static text over the 3D scene).
#if defined VERTEX_SHADER
in vec2 in_pos;     // pixels, y down
in vec2 in_uv;      // atlas coordinates, v down
uniform vec2 u_viewport;
out vec2 v_uv;
void main() {
    vec2 ndc = vec2(in_pos.x / u_viewport.x * 2.0 - 1.0, 1.0 - in_pos.y / u_viewport.y * 2.0);
    v_uv = in_uv;
    gl_Position = vec4(ndc, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_atlas;   // R = glyph coverage; row 0 of the image uploaded first (top)
uniform vec4 u_color;
uniform int u_solid;         // 1: plain rectangle of u_color (panel background)
in vec2 v_uv;
out vec4 f_color;
void main() {
    float a = u_solid == 1 ? 1.0 : texture(u_atlas, v_uv).r;
    f_color = vec4(u_color.rgb, u_color.a * a);
}
#endif

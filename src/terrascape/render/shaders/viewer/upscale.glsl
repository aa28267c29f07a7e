// A frame drawn at a fraction of the window's size, enlarged to the window with the linear
// filter: one texture read per window pixel (a Catmull-Rom enlargement needs five, and this
// pass is paid only while the camera moves, when softness shows least). Its cost:
// scripts/viewer_frame_costs.py.
#if defined VERTEX_SHADER
out vec2 v_uv;
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    v_uv = p * 0.5 + 0.5;
    gl_Position = vec4(p, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_frame;   // the small frame, linear filtering, clamped at its edges
in vec2 v_uv;
out vec4 f_color;
void main() {
    f_color = vec4(texture(u_frame, v_uv).rgb, 1.0);
}
#endif

// A frame drawn at a fraction of the window's size, enlarged to the window with a
// Catmull-Rom (cubic B-spline family, B = 0, C = 1/2) filter: sharper than bilinear and
// without its diamond-shaped blur. The 4×4 texel footprint is read in 5 bilinear taps (the
// four corner taps, whose weights are small, are dropped), the standard reduction of the
// 9-tap form that uses the hardware's linear filter to merge pairs of texels.
#if defined VERTEX_SHADER
out vec2 v_uv;
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    v_uv = p * 0.5 + 0.5;
    gl_Position = vec4(p, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_frame;   // the small frame, linear filtering, clamped at its edges
uniform vec2 u_texel;        // 1 / its size in texels
in vec2 v_uv;
out vec4 f_color;
void main() {
    vec2 pos = v_uv / u_texel;
    vec2 centre = floor(pos - 0.5) + 0.5;
    vec2 f = pos - centre;
    // Catmull-Rom weights of the texels at offsets -1, 0, 1, 2
    vec2 w0 = f * (-0.5 + f * (1.0 - 0.5 * f));
    vec2 w1 = 1.0 + f * f * (-2.5 + 1.5 * f);
    vec2 w2 = f * (0.5 + f * (2.0 - 1.5 * f));
    vec2 w3 = f * f * (-0.5 + 0.5 * f);
    // texels 0 and 1 merged into one linear tap between them
    vec2 w12 = w1 + w2;
    vec2 at12 = (centre + w2 / w12) * u_texel;
    vec2 at0 = (centre - 1.0) * u_texel;
    vec2 at3 = (centre + 2.0) * u_texel;
    vec3 c = texture(u_frame, vec2(at12.x, at0.y)).rgb * (w12.x * w0.y)
           + texture(u_frame, vec2(at0.x, at12.y)).rgb * (w0.x * w12.y)
           + texture(u_frame, at12).rgb * (w12.x * w12.y)
           + texture(u_frame, vec2(at3.x, at12.y)).rgb * (w3.x * w12.y)
           + texture(u_frame, vec2(at12.x, at3.y)).rgb * (w12.x * w3.y);
    float total = w12.x * w0.y + w0.x * w12.y + w12.x * w12.y + w3.x * w12.y + w12.x * w3.y;
    // the cubic overshoots at hard edges: keep the result within displayable values
    f_color = vec4(clamp(c / total, 0.0, 1.0), 1.0);
}
#endif

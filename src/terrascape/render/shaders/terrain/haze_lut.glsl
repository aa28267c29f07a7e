// Per-frame look-up table of the sky radiance at the horizon end of a terrain pixel's
// haze (common/terrain_fragment.glsl, terrain_aerial_perspective): the Preetham sky of
// common/atmosphere.glsl evaluated once per table cell instead of once per terrain pixel
// (three Perez terms and an arccos, which a software rasteriser pays on every pixel).
// Cell (u, v): u = sin(φ/2) with φ the azimuth from the sun (the sky is symmetric about
// the sun's vertical plane; sin(φ/2) keeps the sun's glow resolved), v = sqrt(elevation
// sine) (the sky changes fastest just above the horizon).
#if defined VERTEX_SHADER
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
#include "common/atmosphere.glsl"
uniform vec2 u_lut_size;
out vec4 f_color;

void main() {
    vec2 uv = (gl_FragCoord.xy - 0.5) / (u_lut_size - 1.0);  // cell centres at 0 and 1
    float phi = 2.0 * asin(clamp(uv.x, 0.0, 1.0));
    float sin_el = uv.y * uv.y;
    float cos_el = sqrt(max(1.0 - sin_el * sin_el, 0.0));
    vec2 s = u_sky_sun_dir.xz;
    s = dot(s, s) > 1e-12 ? normalize(s) : vec2(1.0, 0.0);
    vec2 h = vec2(cos(phi) * s.x - sin(phi) * s.y, sin(phi) * s.x + cos(phi) * s.y);
    f_color = vec4(sky_radiance(vec3(cos_el * h.x, sin_el, cos_el * h.y)), 1.0);
}
#endif

// The shaders' sRGB transfer curves on a ramp (tests compare them with the standard's):
// pixel column i of an N-wide target holds x = i / (N - 1) and writes
// (linear_to_srgb(x), srgb_to_linear(x), x, 1) to a float attachment.
#if defined VERTEX_SHADER
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
#include "common/atmosphere.glsl"
uniform float u_width;
out vec4 f_color;
void main() {
    float x = floor(gl_FragCoord.x) / (u_width - 1.0);
    f_color = vec4(linear_to_srgb(vec3(x)).r, srgb_to_linear(vec3(x)).r, x, 1.0);
}
#endif

// "plain": one colour texture over the whole terrain (default: the procedural region
// texture of Filipović 2008 §3.1.1, one texel per vertex), lit per the `lighting` parameter.
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
uniform sampler2D u_color_tex;

void main() {
    vec3 albedo = texture(u_color_tex, grid_texcoord(vec2(textureSize(u_color_tex, 0)))).rgb;
    f_color = finish(shade(albedo, normalize(v_normal)));
}
#endif

// "splat": seed 001 §3.1.3 texture splatting in one pass. Alpha maps of up to 8 layers are
// packed 4 per RGBA texture (pack_splat_maps: channel k of map m = layer 4m + k, one texel
// per vertex); the colour is sum_k alpha_k * layer_k(tiled uv).
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
uniform sampler2D u_splat0;
uniform sampler2D u_splat1;
uniform sampler2DArray u_materials;
uniform int u_n_layers;
uniform float u_tile_size;

void main() {
    vec2 guv = grid_texcoord(vec2(textureSize(u_splat0, 0)));
    vec4 a0 = texture(u_splat0, guv);
    vec4 a1 = texture(u_splat1, guv);
    float alpha[8] = float[8](a0.r, a0.g, a0.b, a0.a, a1.r, a1.g, a1.b, a1.a);
    vec2 tile_uv = v_world.xz / u_tile_size;
    vec3 albedo = vec3(0.0);
    for (int k = 0; k < u_n_layers; ++k) {
        if (alpha[k] > 0.0) albedo += alpha[k] * texture(u_materials, vec3(tile_uv, float(k))).rgb;
    }
    f_color = finish(shade(albedo, normalize(v_normal)));
}
#endif

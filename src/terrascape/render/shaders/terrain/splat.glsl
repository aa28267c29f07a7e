// "splat": Filipović 2008 §3.1.3 texture splatting in one pass. Alpha maps of up to 8 layers are
// packed 4 per RGBA texture (pack_splat_maps: channel k of map m = layer 4m + k, one texel
// per vertex); the colour is sum_k alpha_k * layer_k(tiled uv). Each layer is hex-tiled
// (common/hextile.glsl, Mikkelsen 2022; the hexagons' blend weighted by the lookups'
// luminance), so its tile period does not show; hex_tiling = false samples the layers
// wrapped as the seed does.
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
#include "common/hextile.glsl"
uniform sampler2D u_splat0;
uniform sampler2D u_splat1;
uniform sampler2DArray u_materials;
uniform int u_n_layers;
uniform float u_tile_size;
uniform int u_hex_tiling;
uniform float u_hex_rotation;
uniform float u_hex_contrast;
uniform float u_hex_sharpness;
uniform int u_hex_seed;

const vec3 LUMA = vec3(0.2126, 0.7152, 0.0722);

void main() {
    vec2 guv = grid_texcoord(vec2(textureSize(u_splat0, 0)));
    vec4 a0 = texture(u_splat0, guv);
    vec4 a1 = texture(u_splat1, guv);
    float alpha[8] = float[8](a0.r, a0.g, a0.b, a0.a, a1.r, a1.g, a1.b, a1.a);
    vec2 tile_uv = v_world.xz / u_tile_size;
    HexTile t = hex_tile(tile_uv, u_hex_rotation, uint(max(u_hex_seed, 0)));
    vec3 albedo = vec3(0.0);
    for (int k = 0; k < u_n_layers; ++k) {
        if (alpha[k] <= 0.0) continue;
        vec3 c;
        if (u_hex_tiling != 0) {
            vec4 a[3];
            hex_fetch_array(u_materials, float(k), t, a);
            vec3 hw = hex_blend_weights(t, vec3(dot(a[0].rgb, LUMA), dot(a[1].rgb, LUMA),
                                                dot(a[2].rgb, LUMA)),
                                        u_hex_contrast, u_hex_sharpness);
            c = hw.x * a[0].rgb + hw.y * a[1].rgb + hw.z * a[2].rgb;
        } else {
            c = texture(u_materials, vec3(tile_uv, float(k))).rgb;
        }
        albedo += alpha[k] * c;
    }
    f_color = finish(shade(albedo, normalize(v_normal)));
}
#endif

// "texture3d": Filipović 2008 §3.1.2. The layer textures are stacked along the depth coordinate r
// of a 3D texture; linear filtering along r blends two neighbouring layers. r comes from
// terrascape.texture.layer_coordinate (one value per vertex, interpolated like the thesis's
// per-vertex glTexCoord3f), the s/t coordinates tile over the terrain. The s/t lookups are
// hex-tiled (common/hextile.glsl, Mikkelsen 2022), so the tile period does not show;
// hex_tiling = false tiles them by wrapping as the seed does.
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
#include "common/hextile.glsl"
uniform sampler3D u_layers;
uniform sampler2D u_layer_coord;
uniform float u_tile_size;
uniform int u_hex_tiling;
uniform float u_hex_rotation;
uniform float u_hex_contrast;
uniform float u_hex_sharpness;
uniform int u_hex_seed;

const vec3 LUMA = vec3(0.2126, 0.7152, 0.0722);

void main() {
    float r = texture(u_layer_coord, grid_texcoord(vec2(textureSize(u_layer_coord, 0)))).r;
    vec2 st = v_world.xz / u_tile_size;
    vec3 albedo;
    if (u_hex_tiling != 0) {
        // The 3D texture has no mip levels (they would average the layers), so plain
        // lookups need no rotated derivatives.
        HexTile t = hex_tile(st, u_hex_rotation, uint(max(u_hex_seed, 0)));
        vec3 a0 = texture(u_layers, vec3(t.uv[0], r)).rgb;
        vec3 a1 = texture(u_layers, vec3(t.uv[1], r)).rgb;
        vec3 a2 = texture(u_layers, vec3(t.uv[2], r)).rgb;
        vec3 hw = hex_blend_weights(t, vec3(dot(a0, LUMA), dot(a1, LUMA), dot(a2, LUMA)),
                                    u_hex_contrast, u_hex_sharpness);
        albedo = hw.x * a0 + hw.y * a1 + hw.z * a2;
    } else {
        albedo = texture(u_layers, vec3(st, r)).rgb;
    }
    f_color = finish(shade(albedo, normalize(v_normal)));
}
#endif

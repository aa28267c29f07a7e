// "material": the default terrain material. Per-vertex layer weights (grass, meadow, rock,
// scree, sediment, snow, water; terrascape.texture.material_weights: slope, height,
// curvature and erosion masks) come packed 4 per RGBA texture; each layer's photo albedo
// (RGB + detail height in A) and detail normal map are hex-tiled (common/hextile.glsl), so
// no texture period shows; the layers are combined by height-based blending (the layer whose
// detail height + weight is highest wins a transition, within u_blend_depth) — the same
// blend as terrascape.texture.material_texture on the CPU. The detail normals of the blend
// perturb the vertex normal in its tangent frame before shade().
#define TERRAIN_TANGENTS
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
#include "common/hextile.glsl"
#define N_LAYERS 7
uniform sampler2D u_weights0;        // layers 0-3 (RGBA), one texel per vertex
uniform sampler2D u_weights1;        // layers 4-6 (RGB)
uniform sampler2DArray u_layers;     // RGB albedo, A detail height
uniform sampler2DArray u_normals;    // RGB tangent-space detail normal
uniform float u_tile_size;           // world units per material repeat
uniform float u_hex_rotation;        // fraction of ±180° each hexagon may turn
uniform float u_hex_contrast;
uniform float u_hex_sharpness;
uniform int u_hex_seed;
uniform float u_blend_depth;         // height-blend transition (detail height units)
uniform float u_detail_strength;     // scales the detail normals' tilt (0: vertex normal)

void main() {
    vec3 N = normalize(v_normal);
    vec3 T = normalize(v_tangent.xyz - N * dot(N, v_tangent.xyz));
    vec3 B = v_tangent.w * cross(N, T);
    vec2 guv = grid_texcoord(vec2(textureSize(u_weights0, 0)));
    vec4 w0 = texture(u_weights0, guv);
    vec4 w1 = texture(u_weights1, guv);
    float w[N_LAYERS] = float[N_LAYERS](w0.r, w0.g, w0.b, w0.a, w1.r, w1.g, w1.b);
    HexTile t = hex_tile(v_world.xz / u_tile_size, u_hex_rotation, uint(max(u_hex_seed, 0)));
    vec3 col[N_LAYERS];
    vec2 nxy[N_LAYERS];
    float hk[N_LAYERS];
    float best = -1e30;
    for (int k = 0; k < N_LAYERS; ++k) {
        hk[k] = -1e30;
        if (w[k] <= 1e-3) continue;
        vec4 a[3];
        hex_fetch_array(u_layers, float(k), t, a);
        vec3 hw = hex_blend_weights(t, vec3(a[0].a, a[1].a, a[2].a), u_hex_contrast,
                                    u_hex_sharpness);
        col[k] = hw.x * a[0].rgb + hw.y * a[1].rgb + hw.z * a[2].rgb;
        hk[k] = hw.x * a[0].a + hw.y * a[1].a + hw.z * a[2].a + w[k];
        vec4 n[3];
        hex_fetch_array(u_normals, float(k), t, n);
        nxy[k] = hw.x * hex_unrotate(t, 0, n[0].xy * 2.0 - 1.0)
               + hw.y * hex_unrotate(t, 1, n[1].xy * 2.0 - 1.0)
               + hw.z * hex_unrotate(t, 2, n[2].xy * 2.0 - 1.0);
        best = max(best, hk[k]);
    }
    vec3 albedo = vec3(0.0);
    vec2 detail = vec2(0.0);
    float total = 0.0;
    for (int k = 0; k < N_LAYERS; ++k) {
        float b = hk[k] - best + u_blend_depth;
        if (b <= 0.0) continue;
        total += b;
        albedo += b * col[k];
        detail += b * nxy[k];
    }
    albedo /= max(total, 1e-6);
    detail = detail / max(total, 1e-6) * u_detail_strength;
    vec3 Nw = normalize(T * detail.x + B * detail.y + N * sqrt(max(1.0 - dot(detail, detail),
                                                                    0.05)));
    f_color = finish(shade(albedo, Nw));
}
#endif

// "material": the default terrain material. Per-vertex layer weights (grass, meadow, rock,
// scree, sediment, snow, water; terrascape.texture.material_weights: slope, height,
// curvature and erosion masks) come packed 4 per RGBA texture; each layer's photo albedo
// (RGB + detail height in A) and detail normal map are hex-tiled (common/hextile.glsl), so
// no texture period shows; the layers are combined by height-based blending (the layer whose
// detail height + weight is highest wins a transition, within u_blend_depth) — the same
// blend as terrascape.texture.material_texture on the CPU. The detail normals of the blend
// perturb the vertex normal in its tangent frame before shade(). Only a pixel's three
// heaviest layers are sampled (MATERIAL_TOP_LAYERS; the CPU blends all of them).
#define TERRAIN_TANGENTS
// MATERIAL_STORED_TANGENTS (a define; the terrain_shading bench's reference): the deferred
// pass reads the tangents from the geometry buffer instead of rebuilding them
#ifndef MATERIAL_STORED_TANGENTS
#define TERRAIN_HEIGHTFIELD_TANGENTS
#endif
#define TERRAIN_SURFACE_NORMALS
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
#include "common/hextile.glsl"
#define N_LAYERS 7
#ifndef MATERIAL_TOP_LAYERS
#define MATERIAL_TOP_LAYERS 3
#endif
uniform sampler2D u_weights0;        // layers 0-3 (RGBA), one texel per vertex
uniform sampler2D u_weights1;        // layers 4-6 (RGB)
uniform sampler2DArray u_layers;     // RGB albedo, A detail height
uniform sampler2DArray u_normals;    // RG: tangent-space detail normal x, y
uniform float u_tile_size;           // world units per material repeat
uniform float u_hex_rotation;        // fraction of ±180° each hexagon may turn
uniform float u_hex_contrast;
uniform float u_hex_sharpness;
uniform int u_hex_seed;
uniform float u_blend_depth;         // height-blend transition (detail height units)
uniform float u_detail_strength;     // scales the detail normals' tilt (0: vertex normal)

void main() {
    vec3 N = surface_normal();
    vec3 T = normalize(v_tangent.xyz - N * dot(N, v_tangent.xyz));
    vec3 B = v_tangent.w * cross(N, T);
    vec2 guv = grid_texcoord(vec2(textureSize(u_weights0, 0)));
    vec4 w0 = texture(u_weights0, guv);
    vec4 w1 = texture(u_weights1, guv);
    float w[N_LAYERS] = float[N_LAYERS](w0.r, w0.g, w0.b, w0.a, w1.r, w1.g, w1.b);
    HexTile t = hex_tile(v_world.xz / u_tile_size, u_hex_rotation, uint(max(u_hex_seed, 0)));
    // Only the MATERIAL_TOP_LAYERS heaviest layers of this pixel are sampled. A software
    // rasteriser runs every instruction of a loop body for every pixel, skipped or not, so
    // the cost is the loop's length; the 4th-heaviest layer weighs at most about 0.2 and
    // rarely reaches the height blend's transition band.
    int idx[MATERIAL_TOP_LAYERS];
    float wt[MATERIAL_TOP_LAYERS];
    for (int j = 0; j < MATERIAL_TOP_LAYERS; ++j) {
        int m = 0;
        for (int k = 1; k < N_LAYERS; ++k) {
            if (w[k] > w[m]) m = k;
        }
        idx[j] = m;
        wt[j] = w[m];
        w[m] = -1.0;
    }
    vec3 col[MATERIAL_TOP_LAYERS];
    vec2 nxy[MATERIAL_TOP_LAYERS];
    float hk[MATERIAL_TOP_LAYERS];
    float best = -1e30;
    for (int j = 0; j < MATERIAL_TOP_LAYERS; ++j) {
        float layer = float(idx[j]);
        vec4 a[3];
        hex_fetch_array(u_layers, layer, t, a);
        vec3 hw = hex_blend_weights(t, vec3(a[0].a, a[1].a, a[2].a), u_hex_contrast,
                                    u_hex_sharpness);
        col[j] = hw.x * a[0].rgb + hw.y * a[1].rgb + hw.z * a[2].rgb;
        // a layer of (almost) no weight takes no part in the blend
        hk[j] = wt[j] > 1e-3 ? hw.x * a[0].a + hw.y * a[1].a + hw.z * a[2].a + wt[j] : -1e30;
        vec4 n[3];
        hex_fetch_array(u_normals, layer, t, n);
        nxy[j] = hw.x * hex_unrotate(t, 0, n[0].xy * 2.0 - 1.0)
               + hw.y * hex_unrotate(t, 1, n[1].xy * 2.0 - 1.0)
               + hw.z * hex_unrotate(t, 2, n[2].xy * 2.0 - 1.0);
        best = max(best, hk[j]);
    }
    vec3 albedo = vec3(0.0);
    vec2 detail = vec2(0.0);
    float total = 0.0;
    for (int j = 0; j < MATERIAL_TOP_LAYERS; ++j) {
        float b = max(hk[j] - best + u_blend_depth, 0.0);
        total += b;
        albedo += b * col[j];
        detail += b * nxy[j];
    }
    albedo /= max(total, 1e-6);
    detail = detail / max(total, 1e-6) * u_detail_strength;
    vec3 Nw = normalize(T * detail.x + B * detail.y + N * sqrt(max(1.0 - dot(detail, detail),
                                                                    0.05)));
    f_color = finish(shade(albedo, Nw));
}
#endif

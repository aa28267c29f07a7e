// "regions": Filipović 2008 §3.1.1 procedural blending evaluated per fragment on the GPU.
//   tezina(h, r) = max(0, (r.range - |h - r.max|) / r.range), normalised over the regions;
// outside every band the nearest band takes weight 1; then the slope rule moves weight
// to rock on steep slopes (as terrascape.texture.region_weights, without jitter). Water is
// all or nothing: weight 1 at or below its band's max (the water line), 0 above it, so no
// water colour climbs the slopes.
// Each region's material texture (texture array layer k) and the grey detail texture in a
// second unit (high-frequency noise, as the seed suggests) are hex-tiled
// (common/hextile.glsl): no texture period shows.
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
#include "common/hextile.glsl"
#define MAX_REGIONS 8
uniform sampler2DArray u_materials;
uniform sampler2D u_detail;
uniform int u_n_regions;
uniform float u_region_max[MAX_REGIONS];
uniform float u_region_range[MAX_REGIONS];
uniform int u_water_index;       // -1: none
uniform int u_rock_index;        // -1: slope rule off
uniform float u_slope_start;     // radians
uniform float u_slope_end;       // radians
uniform float u_tile_size;       // world units per material repeat
uniform float u_detail_size;     // world units per detail repeat
uniform float u_detail_strength; // 0: no detail, 1: full modulation

void main() {
    vec3 N = normalize(v_normal);
    float h = v_world.y / u_exaggeration;  // heights are defined before exaggeration
    float w[MAX_REGIONS];
    float total = 0.0;
    float best = 1e30;
    int best_i = 0;
    bool under_water = u_water_index >= 0
        && (h <= u_region_max[u_water_index] || u_n_regions == 1);
    for (int r = 0; r < u_n_regions; ++r) {
        if (r == u_water_index) {
            w[r] = 0.0;
            continue;
        }
        float dist = abs(h - u_region_max[r]);
        if (dist - u_region_range[r] < best) {
            best = dist - u_region_range[r];
            best_i = r;
        }
        w[r] = max((u_region_range[r] - dist) / u_region_range[r], 0.0);
        total += w[r];
    }
    for (int r = 0; r < u_n_regions; ++r) {
        w[r] = under_water ? (r == u_water_index ? 1.0 : 0.0)
             : (total > 0.0 ? w[r] / total : (r == best_i ? 1.0 : 0.0));
    }
    if (u_rock_index >= 0) {
        // slope of the un-exaggerated surface: tan = |grad h| = |N.xz| / (N.y · e)
        float slope = atan(length(N.xz) / max(N.y * u_exaggeration, 1e-6));
        float t = u_slope_end > u_slope_start
            ? (slope - u_slope_start) / (u_slope_end - u_slope_start)
            : (slope >= u_slope_start ? 1.0 : 0.0);
        t = clamp(t, 0.0, 1.0);
        float keep = u_water_index >= 0 ? w[u_water_index] : 0.0;
        for (int r = 0; r < u_n_regions; ++r) {
            if (r != u_water_index) w[r] *= 1.0 - t;
        }
        w[u_rock_index] += t * (1.0 - keep);
    }
    HexTile t = hex_tile(v_world.xz / u_tile_size, 1.0, 0u);
    const vec3 lum_w = vec3(1.0 / 3.0);
    vec3 albedo = vec3(0.0);
    for (int r = 0; r < u_n_regions; ++r) {
        if (w[r] > 0.0) {
            vec4 a[3];
            hex_fetch_array(u_materials, float(r), t, a);
            vec3 hw = hex_blend_weights(t, vec3(dot(a[0].rgb, lum_w), dot(a[1].rgb, lum_w),
                                                dot(a[2].rgb, lum_w)), 0.6, 7.0);
            albedo += w[r] * (hw.x * a[0].rgb + hw.y * a[1].rgb + hw.z * a[2].rgb);
        }
    }
    HexTile td = hex_tile(v_world.xz / u_detail_size, 1.0, 1u);
    vec4 d[3];
    hex_fetch(u_detail, td, d);
    vec3 dw = hex_blend_weights(td, vec3(d[0].r, d[1].r, d[2].r), 0.6, 7.0);
    float detail = dw.x * d[0].r + dw.y * d[1].r + dw.z * d[2].r;
    albedo *= mix(1.0, 2.0 * detail, u_detail_strength);
    f_color = finish(shade(albedo, N));
}
#endif

// "regions": seed 001 §3.1.1 procedural blending evaluated per fragment on the GPU.
//   tezina(h, r) = max(0, (r.range - |h - r.max|) / r.range), normalised over the regions;
// outside every band the nearest band takes weight 1; then the slope rule moves weight
// to rock on steep slopes (as terrascape.texture.region_weights, without jitter).
// Each region's material texture is tiled (texture array layer k); a grey detail texture
// in a second unit adds high-frequency noise, as the seed suggests.
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
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
    for (int r = 0; r < u_n_regions; ++r) {
        float dist = abs(h - u_region_max[r]);
        if (dist - u_region_range[r] < best) {
            best = dist - u_region_range[r];
            best_i = r;
        }
        w[r] = max((u_region_range[r] - dist) / u_region_range[r], 0.0);
        total += w[r];
    }
    for (int r = 0; r < u_n_regions; ++r) {
        w[r] = total > 0.0 ? w[r] / total : (r == best_i ? 1.0 : 0.0);
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
    vec2 tile_uv = v_world.xz / u_tile_size;
    vec3 albedo = vec3(0.0);
    for (int r = 0; r < u_n_regions; ++r) {
        if (w[r] > 0.0) albedo += w[r] * texture(u_materials, vec3(tile_uv, float(r))).rgb;
    }
    float detail = texture(u_detail, v_world.xz / u_detail_size).r;
    albedo *= mix(1.0, 2.0 * detail, u_detail_strength);
    f_color = finish(shade(albedo, N));
}
#endif

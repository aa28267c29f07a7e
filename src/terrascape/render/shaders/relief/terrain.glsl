// Relief techniques on the terrain mesh (seed 000 §2.6.4: the terrain node gets the tangent
// mesh and the relief material; MISSION R3–R8, R10). Compile with `#define TECHNIQUE n`.
//
// The tiled RGBA normal+height texture is planar-mapped (v_uv = v_grid * u_uv_scale, tiled
// when u_uv_scale > 1, stretched when 1). Per fragment the view ray is taken into uvd space
// with the basis (T * world length of one u unit, B * length of one v unit,
// -N * u_depth * length of one UV unit) — the same geometry as terrascape.relief.reference.
#define TERRAIN_TANGENTS
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
#include "relief/common/heightfield.glsl"

uniform sampler2D u_color_tex;   // colour texture, one texel per vertex (region_texture)
uniform int u_self_shadow;       // R7 on/off
uniform float u_relief_tint;     // how much the relief height darkens the albedo (0..1)
// The A channel of u_relief alone (R32F: the same values and mip chain, so the same
// surface): the march reads only heights, and a one-channel texel is a quarter of the
// memory and filtering work of the RGBA32F one on llvmpipe.
uniform sampler2D u_relief_height;
// Screen-space level of detail of the relief march (terrain_relief_counts).
uniform int u_relief_lod;        // 0: fixed counts (relief 16+8), 1: counts from the view
uniform float u_lod_step;        // linear step length in texels of the sampled mip level
uniform float u_lod_precision;   // binary search stops once the bracket is below this (px)
uniform float u_lod_min_span;    // whole displacement below this (px): one parallax step
uniform float u_lod_nearest_from; // LOD march from this mip level on: nearest level only

float g_march_lod = 0.0;         // level of detail of the march's height fetches

float terrain_depth(vec2 uv) {
    g_fetches += 1;
    return 1.0 - textureLod(u_relief_height, uv, g_march_lod).r;
}

// Parallax mapping Tn = Tv + h'·V.xy/V.z (seed 000 §2.3), the formula of trace_parallax
// with V.xy/V.z = -ds/u_depth written out: no normalisation, the ratio does not need it.
vec3 terrain_parallax(vec2 uv0, vec2 ds) {
    float hs = (1.0 - terrain_depth(uv0)) * u_parallax_scale + u_parallax_bias;
    float inv_depth = 1.0 / max(u_depth, 1e-6);
    return vec3(uv0 - hs * inv_depth * ds, -hs * inv_depth);
}

// Parallax with the LOD fallback: where the largest shift |h'|·|V.xy/V.z| spans less than
// u_lod_min_span pixels of the sampled mip level, the unshifted texture (no height fetch).
// The height fetches' level of detail: g_lod, or with LOD from mip level
// u_lod_nearest_from on (< 0: never) the nearest mip level (GL's *_MIPMAP_NEAREST rule): one
// level's bilinear fetch instead of two, on a slightly different surface where texels are a
// fraction of a pixel. The shading fetch at the hit stays trilinear.
float terrain_march_lod() {
    bool nearest = u_relief_lod != 0 && u_lod_nearest_from >= 0.0 && g_lod > 0.0
        && g_lod >= u_lod_nearest_from;
    return nearest ? round(g_lod) : g_lod;
}

vec3 terrain_parallax_trace(vec2 uv0, vec2 ds) {
    g_march_lod = terrain_march_lod();
    if (u_relief_lod != 0 && g_lod > 0.0) {
        float reach = max(abs(u_parallax_bias), abs(u_parallax_scale + u_parallax_bias));
        float span = reach / max(u_depth, 1e-6)
            * length(ds * vec2(textureSize(u_relief_height, 0))) * exp2(-g_lod);
        if (span < u_lod_min_span) {
            return vec3(uv0, 0.0);
        }
    }
    return terrain_parallax(uv0, ds);
}

// Relief mapping: n linear steps from depth 0 to 1, then k binary steps on the bracket
// (Policarpo et al. 2005, seed 000 §2.4.6–2.4.7): the samples and the result of
// linear_bracket + trace_relief in relief/common/heightfield.glsl, read from
// u_relief_height. Both searches run in one loop of one fetch per iteration: llvmpipe runs a
// loop until its last SIMD lane leaves it, so one loop costs max(linear + binary) over the
// lanes instead of max(linear) + max(binary), and pays the loop's mask bookkeeping once.
// The bottom (s = 1) is never fetched: depth <= 1, so it is always under the surface.
// first = 1 skips the sample at s = 0, which only finds texels of height exactly 1 (the
// bracket [0, 1/n] then refines to them within the binary search's precision).
vec3 terrain_relief(vec2 uv0, vec2 ds, int n, int k, int first) {
    float step_s = 1.0 / float(n);
    float lo = 0.0;
    float hi = 1.0;
    int left = -1;  // binary steps still to take; -1 while the linear search runs
    if (first >= n) {
        left = k;  // no linear sample above the bottom: the bracket is [0, 1]
    }
    float s = left < 0 ? float(first) * step_s : 0.5;
    for (int i = first; i <= n + k && left != 0; ++i) {
        bool inside = s >= terrain_depth(uv0 + s * ds);
        if (inside) {
            hi = s;
        } else {
            lo = s;
        }
        if (left < 0) {
            if (inside) {
                // First sample under the surface; at s = 0 the ray enters at the top.
                left = s > 0.0 ? k : 0;
            } else if (i + 1 >= n) {
                left = k;  // the next linear sample would be the bottom: bracket [s, 1]
            }
        } else {
            left -= 1;
        }
        s = left < 0 ? float(i + 1) * step_s : 0.5 * (lo + hi);
    }
    s = 0.5 * (lo + hi);
    return vec3(uv0 + s * ds, s);
}

// Step counts of the relief search. Without LOD: the fixed (or angle-adaptive) linear count
// and u_binary_steps. With LOD — Tatarchuk 2006 picks the POM sample count and a fallback by
// the sampled mip level; here the counts follow the ray's length on screen:
//   span = texels of the *sampled* mip level that the ray crosses from depth 0 to 1, about
//          pixels (level g_lod has 2^g_lod level-0 texels per pixel along the footprint's
//          long axis, the direction in which the view foreshortens the parallax shift);
//   linear steps of u_lod_step such texels, never more than without LOD: a finer step
//          would resolve detail the mip level no longer holds;
//   binary steps until the bracket is below u_lod_precision pixels;
//   where the texture is magnified (g_lod <= 0) the full counts, so near views are the
//   unchanged relief 16+8.
// Returns (n, k); n = 0 means that the whole displacement is below u_lod_min_span pixels, so
// that one parallax step is right to within that much.
ivec2 terrain_relief_counts(vec2 ds) {
    int n_full = relief_linear_count(ds);
    if (u_relief_lod == 0 || g_lod <= 0.0) {
        return ivec2(n_full, u_binary_steps);
    }
    float span = length(ds * vec2(textureSize(u_relief_height, 0))) * exp2(-g_lod);
    if (span < u_lod_min_span) {
        return ivec2(0, 0);
    }
    int n = clamp(int(ceil(span / max(u_lod_step, 0.05))), 1, n_full);
    float bracket = span / float(n);
    int k = int(ceil(log2(max(bracket / max(u_lod_precision, 1e-3), 1.0))));
    return ivec2(n, clamp(k, 0, u_binary_steps));
}

vec3 terrain_relief_trace(vec2 uv0, vec2 ds) {
    bool lod = u_relief_lod != 0 && g_lod > 0.0;
    g_march_lod = terrain_march_lod();
    ivec2 nk = terrain_relief_counts(ds);
    if (nk.x == 0) {
        // Whole displacement below u_lod_min_span pixels: the hit at the entry texel's depth.
        float s = terrain_depth(uv0);
        return vec3(uv0 + s * ds, s);
    }
    return terrain_relief(uv0, ds, nk.x, nk.y, lod ? 1 : 0);
}

void main() {
    relief_begin(v_uv);
    vec3 N = normalize(v_normal);
    vec3 T = normalize(v_tangent.xyz - N * dot(N, v_tangent.xyz));
    vec3 B = v_tangent.w * cross(N, T);
    vec2 unit = u_extent / max(u_uv_scale, 1e-6);
    // The basis (T·unit.x, B·unit.y, −N·depth·√(unit.x·unit.y)) has orthogonal columns
    // (T, B, N orthonormal), so its inverse is its transpose with each row divided by that
    // column's squared length: three dot products instead of a 3×3 inverse per fragment.
    vec3 scale = 1.0 / vec3(unit.x, unit.y, -u_depth * sqrt(unit.x * unit.y));
    mat3 to_uvd = transpose(mat3(T, B, N));
    to_uvd = mat3(to_uvd[0] * scale, to_uvd[1] * scale, to_uvd[2] * scale);
    vec3 dir = to_uvd * (v_world - u_camera_pos);
    // On the mesh the local surface can face away from the eye (silhouettes, steep slopes
    // seen from behind): dir.z <= 0 would give an unbounded march. Clamp the ray to at most
    // 8 UV units of drift per unit depth (about 7 degrees above the surface).
    vec2 ds = dir.xy / max(dir.z, 0.125 * length(dir.xy) + 1e-6);
#if TECHNIQUE == TECH_BY_DISTANCE
    vec3 hit = relief_trace_by_distance(v_uv, ds, distance(v_world, u_camera_pos));
#elif TECHNIQUE == TECH_RELIEF
    vec3 hit = terrain_relief_trace(v_uv, ds);
#elif TECHNIQUE == TECH_PARALLAX
    vec3 hit = terrain_parallax_trace(v_uv, ds);
#else
    vec3 hit = relief_trace(v_uv, ds);
#endif
    vec4 t = relief_sample(u_relief, hit.xy);
    vec3 n = t.rgb * 2.0 - 1.0;
    vec3 Nw = normalize(T * n.x + B * n.y + N * n.z);
    vec2 grid = v_grid + (hit.xy - v_uv) / max(u_uv_scale, 1e-6);
    vec2 size = vec2(textureSize(u_color_tex, 0));
    vec3 albedo = texture(u_color_tex, (grid * (size - 1.0) + 0.5) / size).rgb;
    albedo *= 1.0 - u_relief_tint * (1.0 - t.a);
    vec3 L = normalize(u_sun_dir);
    float lit = 1.0;
    if (u_self_shadow != 0) {
        vec3 l = to_uvd * L;
        lit = l.z < 0.0 ? 1.0 - relief_shadow(hit, l.xy / -l.z) : 0.0;
    }
    vec3 color;
    if (u_lighting == 0) {
        color = albedo;
    } else {
        // Shadowed fragments keep the ambient term only.
        color = mix(albedo * u_ka * u_ambient_color, phong(albedo, Nw, L, view_dir()), lit);
    }
    f_color = finish(color);
#ifdef TERRAIN_OUTPUT_FETCHES
    // Benchmark output: height fetches of this fragment (R) and its mip level / 16 (G; 0
    // only where the texture is magnified, at least one step where it is minified).
    float level = g_lod > 0.0 ? clamp(g_lod / 16.0, 1.0 / 255.0, 1.0) : 0.0;
    f_color = vec4(float(g_fetches) / 255.0, level, 1.0, 1.0);
#endif
}
#endif

// Relief techniques on the terrain mesh (Janković 2010 §2.6.4: the terrain node gets the tangent
// mesh and the relief material). Compile with `#define TECHNIQUE n`.
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
uniform int u_self_shadow;       // self-shadowing on/off
uniform float u_relief_tint;     // how much the relief height darkens the albedo (0..1)
// The A channel of u_relief alone (R32F: the same values and mip chain, so the same
// surface): the march reads only heights, and a one-channel texel is a quarter of the
// bytes and of the filtering arithmetic of the RGBA32F one on llvmpipe.
uniform sampler2D u_relief_height;
// Screen-space level of detail of the relief march (terrain_relief_trace).
uniform int u_relief_lod;        // 0: fixed counts (relief 16+8), 1: counts from the view
uniform float u_lod_step;        // linear step length in texels of the sampled mip level
uniform float u_lod_precision;   // binary search stops once the bracket is below this (px)
uniform float u_lod_min_span;    // whole displacement below this (px): one parallax step
uniform float u_lod_nearest_from; // LOD march from this mip level on: nearest level only
uniform float u_lod_clearance;   // LOD: typical slope for clearance-scaled steps (0: equal)
uniform int u_lod_secant;        // LOD: the hit where the bracket's chord crosses, not its middle

float g_march_lod = 0.0;         // level of detail of the march's height fetches

float terrain_depth(vec2 uv) {
    g_fetches += 1;
    return 1.0 - textureLod(u_relief_height, uv, g_march_lod).r;
}

// Parallax mapping Tn = Tv + h'·V.xy/V.z (Janković 2010 §2.3), the formula of trace_parallax
// with V.xy/V.z = -ds/u_depth written out: no normalisation, the ratio does not need it.
vec3 terrain_parallax(vec2 uv0, vec2 ds) {
    float hs = (1.0 - terrain_depth(uv0)) * u_parallax_scale + u_parallax_bias;
    float inv_depth = 1.0 / max(u_depth, 1e-6);
    return vec3(uv0 - hs * inv_depth * ds, -hs * inv_depth);
}

// The height fetches' level of detail: g_lod, or with LOD from mip level
// u_lod_nearest_from on (< 0: never) the nearest mip level (GL's *_MIPMAP_NEAREST rule): one
// level's bilinear fetch instead of two, on a slightly different surface where texels are a
// fraction of a pixel. The shading fetch at the hit stays trilinear.
float terrain_march_lod() {
    bool nearest = u_relief_lod != 0 && u_lod_nearest_from >= 0.0 && g_lod > 0.0
        && g_lod >= u_lod_nearest_from;
    return nearest ? round(g_lod) : g_lod;
}

// Parallax with the LOD fallback: where the largest shift |h'|·|V.xy/V.z| spans less than
// u_lod_min_span pixels of the sampled mip level, the unshifted texture (no height fetch).
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

// Binary steps that shrink a bracket of `width` (in s) below the precision: k_scale is the
// bracket length in precision units per unit of s (0: always k_max).
int terrain_binary_count(float width, int k_max, float k_scale) {
    if (k_scale <= 0.0) {
        return k_max;
    }
    return clamp(int(ceil(log2(max(width * k_scale, 1.0)))), 0, k_max);
}

// Relief mapping: a linear search from depth 0 to 1 in steps of at least 1/n, then binary
// steps on the bracket (Policarpo et al. 2005, Janković 2010 §2.4.6–2.4.7). With first = 0,
// clearance = 0, k_scale = 0 and secant = false these are the samples and the result of
// linear_bracket + trace_relief (relief/common/heightfield.glsl) with n linear and k binary
// steps, read from u_relief_height.
// * Both searches run in one loop of one fetch per iteration: llvmpipe runs a loop until its
//   last SIMD lane leaves it, so one loop costs max(linear + binary) over the lanes instead
//   of max(linear) + max(binary), and pays the loop's mask bookkeeping once.
// * The bottom (s = 1) is never fetched: depth <= 1, so it is always under the surface.
// * first = 1 skips the sample at s = 0, which only finds texels of height exactly 1 (the
//   bracket [0, 1/n] then refines to them within the binary search's precision).
// * clearance > 0: outside the surface by g = depth - s, the next step is
//   max(1/n, g·clearance) — clearance = 1/(1 + G·L) for a surface of slope G (depth per
//   texel) and a ray L texels long is the sphere-tracing bound (Hart 1996); see
//   terrain_relief_trace.
// * k_scale > 0: binary steps until the bracket is below 1/k_scale, at most k.
// * secant: the hit where the chord between the bracket's two samples crosses the surface
//   (POM's interpolation, Tatarchuk 2006) instead of the bracket's middle: on a smooth
//   surface far closer for the same fetches, and never outside the bracket.
vec3 terrain_relief(vec2 uv0, vec2 ds, int n, int k, int first, float clearance,
                    float k_scale, bool secant) {
    float step_s = 1.0 / float(n);
    float lo = 0.0;
    float hi = 1.0;
    float f_lo = 1.0;   // s - depth at lo (< 0) and hi (>= 0); 1 and -1: not sampled
    float f_hi = -1.0;
    int left = -1;      // binary steps still to take; -1 while the linear search runs
    float s = float(first) * step_s;
    if (first >= n) {
        left = terrain_binary_count(1.0, k, k_scale);  // bracket [0, 1]
        s = 0.5;
    }
    for (int i = first; i <= n + k && left != 0; ++i) {
        float f = s - terrain_depth(uv0 + s * ds);
        bool inside = f >= 0.0;
        if (inside) {
            hi = s;
            f_hi = f;
        } else {
            lo = s;
            f_lo = f;
        }
        // Equal steps as float(i + 1) / n exactly, as linear_bracket computes them.
        float next = clearance > 0.0 ? s + max(step_s, -f * clearance) : float(i + 1) * step_s;
        if (left < 0) {
            if (inside) {
                // First sample under the surface; at s = 0 the ray enters at the top.
                left = s > 0.0 ? terrain_binary_count(hi - lo, k, k_scale) : 0;
            } else if (next >= 1.0 - 1e-6) {
                // The next linear sample would be the bottom: the bracket is [s, 1].
                left = terrain_binary_count(1.0 - lo, k, k_scale);
            }
        } else {
            left -= 1;
        }
        s = left < 0 ? next : 0.5 * (lo + hi);
    }
    s = 0.5 * (lo + hi);
    if (secant && f_lo < 0.0 && f_hi >= 0.0) {
        s = lo + (hi - lo) * (-f_lo / (f_hi - f_lo));
    }
    return vec3(uv0 + s * ds, s);
}

// Relief mapping on the terrain. Without LOD, or where the texture is magnified (g_lod <= 0,
// so near views are the unchanged relief 16+8): the fixed (or angle-adaptive) linear count
// and u_binary_steps. With LOD — Tatarchuk 2006 picks the POM sample count and a fallback by
// the sampled mip level; here the counts follow the ray's length on screen:
//   span = texels of the *sampled* mip level that the ray crosses from depth 0 to 1, about
//          pixels (level g_lod has 2^g_lod level-0 texels per pixel along the footprint's
//          long axis, the direction in which the view foreshortens the parallax shift);
//   linear steps of u_lod_step such texels, never more than without LOD: a finer step
//          would resolve detail the mip level no longer holds; longer steps by clearance
//          where u_lod_clearance (the slope G, depth per texel of the sampled level) > 0;
//   binary steps until the bracket is below u_lod_precision pixels, then the secant hit
//          (u_lod_secant);
//   below u_lod_min_span pixels of span one parallax step, right to within that much.
vec3 terrain_relief_trace(vec2 uv0, vec2 ds) {
    g_march_lod = terrain_march_lod();
    int n_full = relief_linear_count(ds);
    if (u_relief_lod == 0 || g_lod <= 0.0) {
        return terrain_relief(uv0, ds, n_full, u_binary_steps, 0, 0.0, 0.0, false);
    }
    float span = length(ds * vec2(textureSize(u_relief_height, 0))) * exp2(-g_lod);
    if (span < u_lod_min_span) {
        float s = terrain_depth(uv0);  // the hit at the entry texel's depth
        return vec3(uv0 + s * ds, s);
    }
    int n = clamp(int(ceil(span / max(u_lod_step, 0.05))), 1, n_full);
    float clearance = u_lod_clearance > 0.0 ? 1.0 / (1.0 + u_lod_clearance * span) : 0.0;
    return terrain_relief(uv0, ds, n, u_binary_steps, 1, clearance,
                          span / max(u_lod_precision, 1e-3), u_lod_secant != 0);
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
    if (LIGHTING_MODE == 0) {
        color = unlit(albedo);
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

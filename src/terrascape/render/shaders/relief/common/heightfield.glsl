// Height-field tracing shared by every relief technique (Janković 2010 §2.3–2.4,,
//. Include from a fragment shader; select the tracer with `#define TECHNIQUE n`.
//
// Geometry (the same as terrascape.relief.reference, so GPU and CPU agree pixel by pixel):
//   the relief hangs below the polygon; a point is (uv, s) with s = normalised depth in [0, 1]
//   (s = 1 - height, height in the A channel of u_relief). A view ray entering the polygon at
//   uv0 is uv0 + s * ds; ds = UV offset per unit depth (from the uvd-space view direction).
//   V = normalize(vec3(-ds, u_depth)) is the classic unit tangent-space vector toward the eye.
//
// Every tracer returns vec3(hit uv, hit depth s). g_fetches counts texture fetches so the
// quality benchmark can report fetches per pixel without a GPU profiler.
//
// TECH_PLAIN, TECH_RELIEF, … (the tracers' ids) are defined by the shader loader from
// terrascape.render.techniques.RELIEF_TRACERS.

uniform sampler2D u_relief;        // RGB tangent-space normal (n*0.5+0.5), A height in [0, 1]
uniform float u_depth;             // relief depth in UV units (seed: the parallax "scale")
uniform float u_parallax_scale;    // h' = scale * h + bias
uniform float u_parallax_bias;
uniform int u_linear_steps;        // relief / interval / steep / POM linear search
uniform int u_binary_steps;        // relief binary steps (~8, §2.4.7) / interval secant steps
uniform int u_adaptive;            // 1: linear step count follows the ray's texel length;
                                   // 2: relief only, clearance-scaled steps (trace_relief)
uniform float u_step_texels;       // adaptive: target linear step length in texels
uniform int u_max_steps;           // adaptive: upper bound of the linear step count
uniform float u_clearance_slope;   // clearance steps: assumed surface slope (depth / texel)
uniform float u_min_step_texels;   // clearance steps: shortest step, in texels
uniform int u_cone_steps;          // cone step mapping iterations
uniform int u_shadow_steps;        // self-shadowing: most linear steps toward the light
uniform float u_shadow_step_texels; // self-shadowing: step length in texels (0: u_shadow_steps)

#if TECHNIQUE == TECH_CONE
uniform sampler2D u_cone;          // NEAREST: R = apex depth, G = cone ratio (UV / depth)
#endif
#if TECHNIQUE == TECH_MINMAX
// One RGBA mip chain (terrascape.relief.minmax_mip.packed_minmax_mip): level 0 = cell (i, j)'s
// corner depths (i,j), (i+1,j), (i,j+1), (i+1,j+1); level k = (min, max, min, max) of 2^k cells.
uniform sampler2D u_minmax;
uniform int u_minmax_levels;
uniform int u_max_iterations;
#endif

int g_fetches = 0;
vec2 g_uv_dx = vec2(0.0);
vec2 g_uv_dy = vec2(0.0);
float g_lod = 0.0;

// Gradients of the *base* texture coordinate, taken in uniform control flow so the
// sampling inside loops keeps correct mip selection. The level of detail is computed once
// from them (GL's isotropic rule: log2 of the longer footprint axis in texels) and every
// fetch uses textureLod: the same level as textureGrad would pick, but llvmpipe would
// otherwise redo the gradient-to-LOD work per fetch and per pixel.
void relief_begin(vec2 uv0) {
    g_fetches = 0;
    g_uv_dx = dFdx(uv0);
    g_uv_dy = dFdy(uv0);
    vec2 size = vec2(textureSize(u_relief, 0));
    float rho = max(length(g_uv_dx * size), length(g_uv_dy * size));
    g_lod = log2(max(rho, 1e-8));
}

vec4 relief_sample(sampler2D tex, vec2 uv) {
    return textureLod(tex, uv, g_lod);
}

vec4 relief_texel(vec2 uv) {
    g_fetches += 1;
    return relief_sample(u_relief, uv);
}

float relief_depth(vec2 uv) {
    return 1.0 - relief_texel(uv).a;
}

// --- parallax -------------------------------------------------------------------

// Tn = Tv + h' * V.xy / V.z  (Janković 2010 §2.3, Kaneko et al. 2001)
vec3 trace_parallax(vec2 uv0, vec3 V) {
    float h = relief_texel(uv0).a;
    float hs = h * u_parallax_scale + u_parallax_bias;
    vec2 uv = uv0 + hs * V.xy / V.z;
    return vec3(uv, -hs / max(u_depth, 1e-6));
}

// Tn = Tv + h' * V.xy  (offset limiting, Welsh 2004, Janković 2010 §2.3.2)
vec3 trace_offset_limiting(vec2 uv0, vec3 V) {
    float h = relief_texel(uv0).a;
    float hs = h * u_parallax_scale + u_parallax_bias;
    vec2 uv = uv0 + hs * V.xy;
    return vec3(uv, -hs / max(u_depth, 1e-6));
}

// --- ray-marched family -------------------------------------------------------

int relief_linear_count(vec2 ds) {
    if (u_adaptive != 1) {
        return max(u_linear_steps, 1);
    }
    // Angle-adaptive: as many steps as the ray's horizontal length in texels / step length,
    // never fewer than the fixed count (steep views need few, grazing views many).
    float texels = length(ds * vec2(textureSize(u_relief, 0)));
    int n = int(ceil(texels / max(u_step_texels, 0.05)));
    return clamp(n, max(u_linear_steps, 1), max(u_max_steps, 1));
}

// Linear search from depth 0 to 1 (§2.4.7): returns (last outside s, first inside s,
// f at those two points) with f = s - depth(s) (< 0 outside, >= 0 inside).
vec4 linear_bracket(vec2 uv0, vec2 ds, int n) {
    float step_s = 1.0 / float(n);
    float s_out = 0.0;
    float f_out = -relief_depth(uv0);
    if (f_out >= 0.0) {
        return vec4(0.0, 0.0, f_out, f_out);
    }
    float s_in = 1.0;
    float f_in = 0.0;
    for (int i = 1; i <= n; ++i) {
        float s = float(i) * step_s;
        float f = s - relief_depth(uv0 + s * ds);
        if (f >= 0.0) {
            s_in = s;
            f_in = f;
            break;
        }
        s_out = s;
        f_out = f;
    }
    return vec4(s_out, s_in, f_out, f_in);
}

vec3 trace_steep(vec2 uv0, vec2 ds) {
    vec4 b = linear_bracket(uv0, ds, relief_linear_count(ds));
    return vec3(uv0 + b.y * ds, b.y);
}

// Parallax occlusion mapping: the bracket's two samples joined by a line (Tatarchuk 2006).
vec3 trace_pom(vec2 uv0, vec2 ds) {
    vec4 b = linear_bracket(uv0, ds, relief_linear_count(ds));
    float denom = b.w - b.z;
    float s = denom > 1e-9 ? b.x + (b.y - b.x) * (-b.z / denom) : b.y;
    return vec3(uv0 + s * ds, s);
}

// Relief mapping: linear search then binary search (Policarpo et al. 2005, §2.4.6–2.4.7).
//
// The linear search walks the ray from depth 0 toward depth 1 and stops at the first sample
// under the surface; the binary search then halves the bracket [last outside, first inside]
// u_binary_steps times. Where the linear samples sit (u_adaptive):
//   0: n = u_linear_steps equal steps (the thesis's "δ times the length AB");
//   1: equal steps, n from the ray's length in texels (u_step_texels per step);
//   2: clearance-scaled steps. At a sample outside the surface the ray is g = depth − s above
//      it; a surface of slope G (depth per texel) can rise to meet a ray that descends
//      1/L per texel (L = ray length in texels from depth 0 to 1) only after
//      Δs = g / (1 + G·L) — the sphere-tracing bound (Hart 1996) with a global Lipschitz
//      constant. G = u_clearance_slope is a *typical* slope, not the maximum, so steps are
//      long far above the surface and short where the ray grazes it (where a fixed step
//      skips thin crests, the > 1 texel errors of relief 16+8 at 70°); each step is kept in
//      [u_min_step_texels texels, 1/u_linear_steps] and at most u_max_steps are taken.
// Two samples are known without a fetch: s = 0 lies on the polygon (under the surface only
// where the depth there is 0, which the binary search from 0 then finds) and s = 1 is always
// under or on it (depth <= 1).
vec2 relief_linear_search(vec2 uv0, vec2 ds) {
    if (u_adaptive == 2) {
        float texels = length(ds * vec2(textureSize(u_relief, 0)));
        float max_step = 1.0 / float(max(u_linear_steps, 1));
        float min_step = min(u_min_step_texels / max(texels, 1e-6), max_step);
        float k = 1.0 / (1.0 + u_clearance_slope * texels);
        float s_out = 0.0;
        float s = max_step;  // no clearance known at s = 0: the longest step
        for (int i = 0; i < u_max_steps; ++i) {
            if (s >= 1.0) {
                return vec2(s_out, 1.0);
            }
            float gap = relief_depth(uv0 + s * ds) - s;
            if (gap <= 0.0) {
                return vec2(s_out, s);
            }
            s_out = s;
            s += clamp(gap * k, min_step, max_step);
        }
        return vec2(s_out, 1.0);  // step budget spent: bracket the rest of the ray
    }
    int n = relief_linear_count(ds);
    float step_s = 1.0 / float(n);
    for (int i = 1; i < n; ++i) {
        float s = float(i) * step_s;
        if (s >= relief_depth(uv0 + s * ds)) {
            return vec2(s - step_s, s);
        }
    }
    return vec2(1.0 - step_s, 1.0);
}

// u_binary_steps halvings of the bracket [lo, hi] (lo outside, hi inside); the hit is the
// final bracket's middle (§2.4.7).
vec3 binary_refine(vec2 uv0, vec2 ds, float lo, float hi) {
    for (int i = 0; i < u_binary_steps; ++i) {
        float mid = 0.5 * (lo + hi);
        if (mid >= relief_depth(uv0 + mid * ds)) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    float s = 0.5 * (lo + hi);
    return vec3(uv0 + s * ds, s);
}

vec3 trace_relief(vec2 uv0, vec2 ds) {
    vec2 b = relief_linear_search(uv0, ds);
    return binary_refine(uv0, ds, b.x, b.y);
}

// Interval mapping: the same bracket refined by secant (regula falsi) steps (Risser 2006,
// §2.4.9): the next point is where the line between the inside and outside samples crosses.
vec3 trace_interval(vec2 uv0, vec2 ds) {
    vec4 b = linear_bracket(uv0, ds, relief_linear_count(ds));
    float lo = b.x, hi = b.y, f_lo = b.z, f_hi = b.w;
    float s = hi;
    if (hi > lo) {
        for (int i = 0; i < u_binary_steps; ++i) {
            float denom = f_hi - f_lo;
            s = denom > 1e-9 ? lo + (hi - lo) * (-f_lo / denom) : 0.5 * (lo + hi);
            float f = s - relief_depth(uv0 + s * ds);
            if (f >= 0.0) {
                hi = s;
                f_hi = f;
            } else {
                lo = s;
                f_lo = f;
            }
        }
        float denom = f_hi - f_lo;
        s = denom > 1e-9 ? lo + (hi - lo) * (-f_lo / denom) : 0.5 * (lo + hi);
    }
    return vec3(uv0 + s * ds, s);
}

#if TECHNIQUE == TECH_CONE
// Cone step mapping (Dummer 2006) with a cone map that is conservative for the bilinear
// surface (terrascape.relief.cone_map.footprint_cone_map): u_cone is sampled NEAREST and
// holds (apex depth = shallowest surface over the texel footprint, cone ratio). Above the
// apex the ray jumps to the cone border; below it the bilinear surface is tested and the ray
// creeps half a texel. The first inside sample is refined by binary steps.
vec3 trace_cone(vec2 uv0, vec2 ds) {
    float s = 0.0;
    float s_prev = 0.0;
    float lds = length(ds);
    float creep = 0.5 / (max(lds, 1e-6) * float(textureSize(u_relief, 0).x));
    bool inside = false;
    for (int i = 0; i < u_cone_steps; ++i) {
        vec2 uv = uv0 + s * ds;
        g_fetches += 1;
        vec2 ac = texture(u_cone, uv).rg;
        if (s < ac.r) {
            s_prev = s;
            // A floor of 1e-4 texel-equivalents keeps the asymptotic approach moving.
            s = min(s + max(ac.g * (ac.r - s) / (lds + ac.g), 1e-4 * creep), 1.0);
            continue;
        }
        if (s >= relief_depth(uv)) {
            inside = true;
            break;
        }
        s_prev = s;
        s = min(s + creep, 1.0);
    }
    if (!inside) {
        return vec3(uv0 + s * ds, s);
    }
    return binary_refine(uv0, ds, s_prev, s);
}
#endif

#if TECHNIQUE == TECH_MINMAX
// In a bilinear cell the ray's height above the surface, g(u) = s(t + u) − B(p(t + u)), is
// the quadratic q.x u² + q.y u + q.z. cell_crossed: does g reach 0 in [0, u_max]? With
// g(0) = q.z < 0: yes if g(u_max) >= 0; otherwise only a concave g whose vertex
// −q.y / (2 q.x) lies inside with g(vertex) >= 0 (disc >= 0) does — no division, no root.
bool cell_crossed(vec3 q, float u_max) {
    float disc = q.y * q.y - 4.0 * q.x * q.z;
    return q.z >= 0.0 || (q.x * u_max + q.y) * u_max + q.z >= 0.0
        || (q.x < 0.0 && q.y > 0.0 && q.y < -2.0 * q.x * u_max && disc >= 0.0);
}

// The first crossing of a crossed cell: (−q.y + √disc) / (2 q.x) whatever the sign of q.x
// (convex: the one positive root; concave: the nearer of two), written 2 q.z / (−q.y − √disc)
// (one division, no cancellation as q.x → 0, where it tends to −q.z / q.y); clamped to the
// cell against rounding.
float cell_root(vec3 q, float u_max) {
    if (q.z >= 0.0) {
        return 0.0;
    }
    float disc = max(q.y * q.y - 4.0 * q.x * q.z, 0.0);
    return clamp(2.0 * q.z / (-q.y - sqrt(disc)), 0.0, u_max);
}

// Exact hierarchical tracer over the min/max mip (Tevs et al. 2008): skip every node whose
// shallowest point the ray does not reach; in a bilinear cell solve the quadratic exactly.
// Ray: p(t) = p0 + t * d (texel-centre units), depth s(t) = s0 + sgn * t, t in [0, t_end].
// Returns the first t where s(t) >= surface depth, or -1.
//
// Cost on a CPU rasteriser is ALU per visited node, so the walk keeps the node as an integer
// index: leaving a node through its x or y face is node ± 1 on that axis (no floor of a
// recomputed point), its parent is node >> 1, the exit distance uses a precomputed 1/d, and
// only a descent (or a free fall inside a node) locates the point again. Level 0 reads the
// cell's four corner depths instead of its min, so a cell costs one fetch.
// The walk starts at level `start` (a view ray: MINMAX_START, not the level spanning the
// whole ray, whose nodes hold the field's shallowest point and are always descended) and
// climbs one level when the next node has another ancestor `climb` levels up.
#ifndef MINMAX_START
#define MINMAX_START 4
#endif
float minmax_march(vec2 p0, vec2 d, float s0, float sgn, float t_end, int start, int climb) {
    ivec2 size = textureSize(u_relief, 0);
    float span = length(d) * t_end + 2.0;
    int top = min(u_minmax_levels - 1, int(ceil(log2(span))));
    int level = min(top, start);
    vec2 dir = vec2(d.x >= 0.0 ? 1.0 : -1.0, d.y >= 0.0 ? 1.0 : -1.0);
    vec2 inv_d = 1.0 / (dir * max(abs(d), vec2(1e-7)));
    vec2 ahead = step(0.0, dir);
    ivec2 idir = ivec2(dir);
    vec2 nudge = dir * 1e-3;  // a point on a node border belongs to the node ahead
    ivec2 node = ivec2(floor(p0 + nudge)) >> level;
    float t = 0.0;
    vec3 hit_q = vec3(0.0);
    float hit_u = -1.0;
    float hit_t = 0.0;
    for (int it = 0; it < u_max_iterations; ++it) {
        g_fetches += 1;
        float cells = float(1 << level);
        vec2 tb = ((vec2(node) + ahead) * cells - p0) * inv_d;
        float t_exit = min(min(tb.x, tb.y), t_end);
        // Power-of-two sizes: & wraps negative indices too (two's complement).
        ivec2 wrapped = node & ((size >> level) - 1);
        vec4 c4 = texelFetch(u_minmax, wrapped, level);
        float node_min = min(min(c4.r, c4.g), min(c4.b, c4.a));
        // Deepest point of the segment: its exit going down (view), its start going up.
        float s_deep = s0 + sgn * (sgn > 0.0 ? t_exit : t);
        if (s_deep >= node_min) {
            if (sgn > 0.0) {
                t = max(t, node_min - s0);  // free fall to the node's highest point
            }
            if (level > 0) {
                // A view ray goes down two levels at once: the intermediate node's test costs
                // a visit and rarely skips what its four children would not (fewer visits at
                // 30–80°); a light ray, rising away from the surface, one.
                int down = min(level, sgn > 0.0 ? 2 : 1);
                level -= down;
                ivec2 child = ivec2(floor(p0 + t * d + nudge)) >> level;
                node = clamp(child, node << down, (node << down) + ((1 << down) - 1));
                continue;
            }
            // Level 0: the bilinear cell with corners at texel centres node, node + 1.
            float a1 = c4.g - c4.r, a2 = c4.b - c4.r, a3 = c4.r - c4.g - c4.b + c4.a;
            vec2 f = p0 + t * d - vec2(node);     // local coordinates at the segment start
            // g(u) = s(t + u) - B(f + u d) as a quadratic in u (see cell_crossed).
            vec3 q = vec3(
                -a3 * d.x * d.y,
                sgn - (a1 * d.x + a2 * d.y + a3 * (f.x * d.y + f.y * d.x)),
                (s0 + sgn * t) - (c4.r + a1 * f.x + a2 * f.y + a3 * f.x * f.y));
            // Only test here; the root is paid once, after the loop, for the cell that
            // holds the hit (in SIMD lanes: not for every lane's every cell).
            float u_max = t_exit - t;
            if (cell_crossed(q, u_max)) {
                hit_q = q;
                hit_u = u_max;
                hit_t = t;
                break;
            }
        }
        if (t_exit >= t_end) {
            return -1.0;
        }
        // Leave the node through the face the ray crosses first. For a view ray climb one
        // level only when the next node also has another grandparent (climb = 2): climbing
        // at every parent border (Tevs 2008), or several levels at once, re-descends more
        // often than it skips on these fields (more visited nodes, measured at 30–80°).
        t = t_exit;
        ivec2 next = node + (tb.x < tb.y ? ivec2(idir.x, 0) : ivec2(0, idir.y));
        if (level < top && any(notEqual(next >> climb, node >> climb))) {
            level += 1;
            node = next >> 1;
        } else {
            node = next;
        }
    }
    if (hit_u < 0.0) {
        return t;  // iteration budget exhausted: best estimate so far
    }
    return hit_t + cell_root(hit_q, hit_u);
}

vec3 trace_minmax(vec2 uv0, vec2 ds) {
    vec2 size = vec2(textureSize(u_relief, 0));
    float t = minmax_march(uv0 * size - 0.5, ds * size, 0.0, 1.0, 1.0, MINMAX_START, 2);
    float s = t < 0.0 ? 1.0 : t;
    return vec3(uv0 + s * ds, s);
}
#endif

// --- self-shadowing toward the light (§2.4.8) ------------------------------------------

// lds = UV offset per unit of depth *decrease* toward the light. Returns 1 in shadow.
float relief_shadow(vec3 hit, vec2 lds) {
    if (hit.z <= 1e-4) {
        return 0.0;
    }
#if TECHNIQUE == TECH_MINMAX
    // Exact: any point of the light ray (going up) under the surface?
    vec2 size = vec2(textureSize(u_relief, 0));
    float eps = 2e-3;
    vec2 p0 = (hit.xy + eps * lds) * size - 0.5;
    // The light ray starts on the surface, so the cell it starts in is always solved: walk
    // up from level 0, climbing at every parent border (the ray rises away from the
    // surface, so ever larger nodes lie below it).
    float t = minmax_march(p0, lds * size, hit.z - eps, -1.0, hit.z - eps, 0, 1);
    return t >= 0.0 ? 1.0 : 0.0;
#else
    // March from the hit toward the light (Policarpo 2005 traces the same segment from the
    // light's entry point); in shadow if a sample lies under the surface.
    // The start is the surface point at the hit's uv: the search's hit lies up to half its
    // last bracket inside or above the surface, and on a steep face that is a large depth
    // error (a start inside the face shadows itself, one above it misses the face's own
    // occluders). The reference (terrascape.relief.reference.shadow_exact) also starts on
    // the surface and calls a point shadowed when any point of its light ray is under it.
    // Steps are u_shadow_step_texels texels of the light ray's horizontal length (thin
    // walls are one texel), at most u_shadow_steps of them; samples at step midpoints. A
    // sample counts as under the surface 1e-3 below it (1e-5 agrees as well with the
    // reference; counting near misses above it as shadowed agrees far worse).
    float s0 = relief_depth(hit.xy);
    if (s0 <= 1e-4) {
        return 0.0;
    }
    float texels = s0 * length(lds * vec2(textureSize(u_relief, 0)));
    int n = clamp(int(ceil(texels / max(u_shadow_step_texels, 0.05))), 1,
                  max(u_shadow_steps, 1));
    float step_t = s0 / float(n);
    for (int i = 0; i < n; ++i) {
        float t = (float(i) + 0.5) * step_t;
        if (s0 - t > relief_depth(hit.xy + t * lds) + 1e-3) {
            return 1.0;
        }
    }
    return 0.0;
#endif
}

// --- dispatch ---------------------------------------------------------------------------

vec3 relief_trace(vec2 uv0, vec2 ds) {
    vec3 V = normalize(vec3(-ds, u_depth));
#if TECHNIQUE == TECH_PLAIN
    return vec3(uv0, 0.0);
#elif TECHNIQUE == TECH_PARALLAX
    return trace_parallax(uv0, V);
#elif TECHNIQUE == TECH_OFFSET_LIMITING
    return trace_offset_limiting(uv0, V);
#elif TECHNIQUE == TECH_STEEP
    return trace_steep(uv0, ds);
#elif TECHNIQUE == TECH_POM
    return trace_pom(uv0, ds);
#elif TECHNIQUE == TECH_RELIEF
    return trace_relief(uv0, ds);
#elif TECHNIQUE == TECH_INTERVAL
    return trace_interval(uv0, ds);
#elif TECHNIQUE == TECH_CONE
    return trace_cone(uv0, ds);
#elif TECHNIQUE == TECH_MINMAX
    return trace_minmax(uv0, ds);
#else
    return vec3(uv0, 0.0);
#endif
}

// Technique by distance (the thesis's conclusion): relief near, parallax farther, plain
// far, each transition blended over u_dist_band world units.
uniform float u_dist_relief;     // relief up to this distance
uniform float u_dist_parallax;   // parallax up to this distance, plain beyond
uniform float u_dist_band;       // blend band width

vec3 relief_trace_by_distance(vec2 uv0, vec2 ds, float dist) {
    vec3 V = normalize(vec3(-ds, u_depth));
    float band = max(u_dist_band, 1e-6);
    float w_relief = 1.0 - smoothstep(u_dist_relief, u_dist_relief + band, dist);
    float w_plain = smoothstep(u_dist_parallax, u_dist_parallax + band, dist);
    vec3 r = vec3(uv0, 0.0);
    if (w_plain < 1.0) {
        vec3 p = trace_parallax(uv0, V);
        vec3 near_hit = p;
        if (w_relief > 0.0) {
            vec3 rel = trace_relief(uv0, ds);
            near_hit = mix(p, rel, w_relief);
        }
        r = mix(near_hit, vec3(uv0, 0.0), w_plain);
    }
    return r;
}

#ifdef RELIEF_FORCE_COMPILE_ERROR
// Lets tests exercise the fallback path (): this line is not GLSL.
this_is_a_forced_compile_error
#endif

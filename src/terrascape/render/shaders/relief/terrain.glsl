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
}
#endif

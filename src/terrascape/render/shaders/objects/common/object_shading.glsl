// Fragment shading of objects on the terrain: the terrain's lighting model (daylight or
// Phong, common/lighting.glsl), its aerial perspective or fog. The sun reaches a point when
// neither an object (the sun's cascaded shadow maps, common/cascades.glsl) nor the terrain
// is in the way: the terrain's shadow is ray-cast through its height texture toward the sun
// from the point itself (exact at any height above the ground, the same test as the
// terrain's own shadow sweep); the sky light is the terrain's sky-view factor at the foot.
#include "common/lighting.glsl"
#include "common/atmosphere.glsl"
#include "common/fog.glsl"
#include "common/cascades.glsl"

uniform vec3 u_camera_pos;
uniform int u_lighting;       // 0 none, 1 Phong, 2 lightmap, 3 daylight (as the terrain)
uniform sampler2D u_sun_sky;  // the terrain's (sun, sky) visibility per vertex
uniform int u_has_sun_sky;
uniform sampler2D u_height;   // the terrain's heights as drawn, one texel per vertex
uniform int u_has_height;
uniform int u_shadow_march;   // the terrain's shadows are on (parameter shadows)
uniform vec2 u_extent;
uniform vec2 u_spacing;
uniform vec2 u_height_range;  // lowest and highest drawn height

// 1 when the ray from p toward the sun leaves the terrain's box without passing under its
// surface, else 0. Steps start at one grid cell and grow by 8 % each.
float terrain_sun_visibility(vec3 p) {
    if (u_has_height == 0 || u_shadow_march == 0) {
        return 1.0;
    }
    vec3 d = u_sun_dir;
    if (d.y <= 0.0) {
        return 0.0;
    }
    vec2 size = vec2(textureSize(u_height, 0));
    float cell = min(u_spacing.x, u_spacing.y);
    float t_top = (u_height_range.y - p.y) / d.y;
    float t = cell;
    float dt = cell;
    for (int i = 0; i < 128 && t < t_top; ++i) {
        vec3 q = p + d * t;
        vec2 g = q.xz / u_extent;
        if (any(lessThan(g, vec2(0.0))) || any(greaterThan(g, vec2(1.0)))) {
            break;
        }
        if (texture(u_height, (g * (size - 1.0) + 0.5) / size).r > q.y + 0.05 * cell) {
            return 0.0;
        }
        t += dt;
        dt *= 1.08;
    }
    return 1.0;
}

vec2 foot_sun_sky(vec2 foot) {
    if (u_has_sun_sky == 0) {
        return vec2(1.0);
    }
    vec2 size = vec2(textureSize(u_sun_sky, 0));
    return texture(u_sun_sky, (foot / u_extent * (size - 1.0) + 0.5) / size).rg;
}

// color: linear albedo; N: unit normal; p: the fragment's world position; q: where its sun
// shadow is looked up; foot: the object's foot (x, z).
vec4 shade_object(vec3 color, vec3 N, vec3 p, vec3 q, vec2 foot) {
    vec2 vis = foot_sun_sky(foot);
    float objects = cascade_sun_visibility(q, N, CASCADE_OBJECT_OFFSET);
    float sun = min(objects, terrain_sun_visibility(q));
    vec3 V = normalize(u_camera_pos - p);
    if (u_lighting == 3) {
        vec3 radiance = daylight_radiance(color, N, sun, vis.y);
        return vec4(display(aerial_perspective(radiance, p, u_camera_pos)), 1.0);
    }
    vec3 albedo = linear_to_srgb(color);
    // unlit: the objects' shadows only, as on the unlit terrain (no shading of its own)
    vec3 c = unlit_sun(albedo, objects);
    if (u_lighting != 0) {
        float ndl = max(dot(N, u_sun_dir), 0.0) * sun;
        c = albedo * (u_ka * u_ambient_color + u_kd * ndl * u_diffuse_color);
    }
    return vec4(apply_fog(c, distance(p, u_camera_pos)), 1.0);
}

// Fragment shading of objects on the terrain: the terrain's lighting model (daylight or
// Phong, common/lighting.glsl), its aerial perspective or fog, the sun's cascaded shadows
// (common/cascades.glsl). Without cascades an object takes the terrain's own sun shadow at
// its foot; in both cases its sky light is the terrain's sky-view factor at its foot.
#include "common/lighting.glsl"
#include "common/atmosphere.glsl"
#include "common/fog.glsl"
#include "common/cascades.glsl"

uniform vec3 u_camera_pos;
uniform int u_lighting;       // 0 none, 1 Phong, 2 lightmap, 3 daylight (as the terrain)
uniform sampler2D u_sun_sky;  // the terrain's (sun, sky) visibility per vertex
uniform int u_has_sun_sky;
uniform vec2 u_extent;

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
    float sun = u_cascade_count > 0 ? cascade_sun_visibility(q, N) : vis.x;
    vec3 V = normalize(u_camera_pos - p);
    if (u_lighting == 3) {
        vec3 radiance = daylight_radiance(color, N, sun, vis.y);
        return vec4(display(aerial_perspective(radiance, p, u_camera_pos)), 1.0);
    }
    vec3 albedo = linear_to_srgb(color);
    vec3 c = albedo;
    if (u_lighting != 0) {
        float ndl = max(dot(N, u_sun_dir), 0.0) * sun;
        c = albedo * (u_ka * u_ambient_color + u_kd * ndl * u_diffuse_color);
    }
    return vec4(apply_fog(c, distance(p, u_camera_pos)), 1.0);
}

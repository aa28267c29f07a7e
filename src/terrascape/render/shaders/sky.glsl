// Sky: a full-screen triangle behind the terrain (drawn where no terrain is).
// Daylight lighting: the Preetham sky with the sun's disc, and below the horizon the world
// beyond the terrain (`surround`): the sea, an infinite plane at the terrain's lowest height,
// or haze — each hazed by aerial perspective, so it meets the sky without a band.
// Other lighting modes: the view ray's elevation blends the horizon colour (also the fog
// colour) to the zenith colour, plus a glow around the sun.
#if defined VERTEX_SHADER
uniform mat4 u_inv_view_proj;
out vec3 v_ray;
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    // World points on the near and far planes are affine in screen position for a
    // perspective projection, so their difference interpolates exactly per vertex and the
    // fragments skip two matrix products (the sky covers most of the screen).
    vec4 a = u_inv_view_proj * vec4(p, -1.0, 1.0);
    vec4 b = u_inv_view_proj * vec4(p, 1.0, 1.0);
    v_ray = b.xyz / b.w - a.xyz / a.w;
    gl_Position = vec4(p, 1.0, 1.0);
}
#elif defined FRAGMENT_SHADER
#include "common/lighting.glsl"
#include "common/atmosphere.glsl"
#include "common/water.glsl"
uniform vec3 u_horizon_color;
uniform vec3 u_zenith_color;
uniform vec3 u_sun_color;
uniform vec3 u_camera_pos;
uniform int u_lighting;
uniform int u_surround;          // 0 fade (haze), 1 plane, 2 sea
uniform float u_surround_height; // world height of the plane / sea
in vec3 v_ray;
out vec4 f_color;

// SKY_MODE (a #define of the program, one program per mode): 0 = not daylight (gradient),
// 1 = daylight with haze beyond the edge, 2 = daylight + plane, 3 = daylight + sea. On a
// software rasteriser every path of a shader costs every pixel, so each mode compiles only
// its own; the uniforms u_lighting / u_surround still say the same.
#ifndef SKY_MODE
#define SKY_MODE 0
#endif

vec3 surround_radiance(vec3 p) {
    // u_surround_albedo (common/water.glsl): the terrain's edge colour
    vec3 ground = daylight_radiance(u_surround_albedo, vec3(0.0, 1.0, 0.0), 1.0, 1.0);
#if SKY_MODE == 3
    float depth = u_sea_level - water_floor(p.xz);
    return water_shade(p, u_camera_pos, depth, ground, true).rgb;
#else
    return ground;
#endif
}

void main() {
    vec3 d = normalize(v_ray);
#if SKY_MODE > 0
    vec3 color;
#if SKY_MODE > 1
    float t = (u_surround_height - u_camera_pos.y) / min(d.y, -1e-6);
    if (d.y < 0.0 && t > 0.0) {
        vec3 p = u_camera_pos + t * d;
        color = aerial_perspective(surround_radiance(p), p, u_camera_pos);
    } else {
        color = sky_radiance(d) + sun_disc(d, u_sun_dir);
    }
#else
    color = sky_radiance(d) + sun_disc(d, u_sun_dir);
#endif
    f_color = vec4(display(color), 1.0);
#else
    float up = clamp(d.y, 0.0, 1.0);
    vec3 color = mix(u_horizon_color, u_zenith_color, sqrt(up));
    if (d.y < 0.0) color = u_horizon_color * (1.0 - 0.25 * clamp(-d.y * 3.0, 0.0, 1.0));
    float s = max(dot(d, normalize(u_sun_dir)), 0.0);
    color += u_sun_color * (pow(s, 512.0) * 2.0 + pow(s, 16.0) * 0.25);
    f_color = vec4(color, 1.0);
#endif
}
#endif

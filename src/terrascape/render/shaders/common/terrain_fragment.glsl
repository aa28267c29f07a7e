// Fragment-stage helpers shared by every terrain technique: inputs, lighting mode, fog.
#include "common/lighting.glsl"
#include "common/fog.glsl"

in vec3 v_world;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
in vec2 v_grid;

out vec4 f_color;

uniform vec3 u_camera_pos;
uniform float u_exaggeration;
uniform int u_lighting;          // 0 none, 1 Phong with the given normal, 2 lightmap
uniform sampler2D u_lightmap;    // one value per vertex (terrascape.lighting.lightmap)

// Texture coordinate of a texture whose texel (i, j) belongs to vertex (i, j) (region
// texture, lightmap, splat maps): texel centres sit at (k + 0.5) / size, corners aligned.
vec2 grid_texcoord(vec2 size) {
    return (v_grid * (size - 1.0) + 0.5) / size;
}

vec3 view_dir() {
    return normalize(u_camera_pos - v_world);
}

// Colour of a surface point with albedo and unit normal N under the chosen lighting mode.
vec3 shade(vec3 albedo, vec3 N) {
    if (u_lighting == 1) {
        return phong(albedo, N, normalize(u_sun_dir), view_dir());
    }
    if (u_lighting == 2) {
        vec2 uv = grid_texcoord(vec2(textureSize(u_lightmap, 0)));
        return albedo * texture(u_lightmap, uv).r;
    }
    return albedo;
}

vec4 finish(vec3 color) {
    return vec4(apply_fog(color, distance(v_world, u_camera_pos)), 1.0);
}

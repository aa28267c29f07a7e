// Water over the terrain: a flat quad at sea level covering the terrain and the sea around
// it (as far as the camera sees; the sky pass continues it to the horizon), or the surface of
// lakes (terrain + a water-depth map), drawn after the terrain with the depth test (terrain
// above the water hides it) and alpha blending (shallow water shows the terrain below);
// common/water.glsl shades it. The depth is the surface height minus the terrain's.
#if defined VERTEX_SHADER
in vec3 in_position;
uniform mat4 u_view_proj;
out vec3 v_world;
void main() {
    v_world = in_position;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
#elif defined FRAGMENT_SHADER
#include "common/lighting.glsl"
#include "common/atmosphere.glsl"
#include "common/water.glsl"
uniform vec3 u_camera_pos;
in vec3 v_world;
out vec4 f_color;
void main() {
    float depth = v_world.y - water_floor(v_world.xz);
    if (depth <= 0.0) discard;
    // Beyond the terrain nothing was drawn below the water: opaque over the sea floor
    // (as the sky pass draws the sea further out); over the terrain, blended with it.
    bool open_sea = !inside_terrain(v_world.xz);
    vec3 floor_radiance = 0.5 * daylight_radiance(u_surround_albedo, vec3(0.0, 1.0, 0.0),
                                                  1.0, 1.0);
    vec4 w = water_shade(v_world, u_camera_pos, depth, floor_radiance, open_sea);
    f_color = vec4(display(aerial_perspective(w.rgb, v_world, u_camera_pos)), w.a);
}
#endif

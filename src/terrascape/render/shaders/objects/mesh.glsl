// Instanced object meshes (terrascape.render.objects): one draw per mesh, each instance its
// foot position, uniform scale and yaw about +Y (Instances.matrices(), the same transform).
// DEPTH_ONLY: the sun's shadow-map pass (u_view_proj is then a cascade's matrix).
#if defined VERTEX_SHADER
in vec3 in_position;
in vec3 in_normal;
in vec3 in_color;
in vec4 in_place;  // xyz foot, w scale
in float in_yaw;
uniform mat4 u_view_proj;
#ifndef DEPTH_ONLY
out vec3 v_world;
out vec3 v_normal;
out vec3 v_color;
flat out vec2 v_foot;
#endif

void main() {
    float c = cos(in_yaw);
    float s = sin(in_yaw);
    vec3 p = in_position * in_place.w;
    vec3 world = vec3(c * p.x + s * p.z, p.y, -s * p.x + c * p.z) + in_place.xyz;
#ifndef DEPTH_ONLY
    v_world = world;
    v_normal = vec3(c * in_normal.x + s * in_normal.z, in_normal.y,
                    -s * in_normal.x + c * in_normal.z);
    v_color = in_color;
    v_foot = in_place.xz;
#endif
    gl_Position = u_view_proj * vec4(world, 1.0);
}
#elif defined FRAGMENT_SHADER
#ifdef DEPTH_ONLY
void main() {
}
#else
#include "objects/common/object_shading.glsl"
in vec3 v_world;
in vec3 v_normal;
in vec3 v_color;
flat in vec2 v_foot;
out vec4 f_color;

void main() {
    vec3 N = normalize(v_normal);
    f_color = shade_object(v_color, N, v_world, v_world, v_foot);
}
#endif
#endif

// Geometry pass of deferred shading (see common/terrain_fragment.glsl): the surface
// attributes every terrain technique reads, per pixel. Compile with TERRAIN_TANGENTS for
// techniques that use the tangent frame.
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
in vec3 v_world;
in vec3 v_normal;
layout(location = 0) out vec4 g_world;
layout(location = 1) out vec4 g_normal;
#ifdef TERRAIN_TANGENTS
in vec4 v_tangent;
layout(location = 2) out vec4 g_tangent;
#endif

void main() {
    g_world = vec4(v_world, 1.0);
    g_normal = vec4(v_normal, 0.0);
#ifdef TERRAIN_TANGENTS
    g_tangent = v_tangent;
#endif
}
#endif

// Vertex stage shared by every terrain technique.
#ifdef DEFERRED
// Deferred shading pass (see common/terrain_fragment.glsl): one full-screen triangle; the
// surface attributes come from the geometry buffer, not from vertices.
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 1.0, 1.0);  // depth 1: drawn where the terrain depth is nearer
}
#else
// Attributes come from terrascape.mesh.terrain_mesh: world position, unit normal and the
// tangent frame (Janković 2010 §2.5) as tangent.xyz + handedness w, so B = w * cross(N, T).
// Only techniques that define TERRAIN_TANGENTS (bump, relief family) read the tangent:
// on llvmpipe vertex fetch and every varying cost triangle-setup time on 2M triangles.
in vec3 in_position;
in vec3 in_normal;
#ifdef TERRAIN_TANGENTS
in vec4 in_tangent;
out vec4 v_tangent;
#endif

uniform mat4 u_view_proj;

out vec3 v_world;
out vec3 v_normal;
// TERRAIN_VERTEX_HAZE (a #define the renderer sets for daylight frames of level-of-detail
// meshes, fewer vertices than pixels): the aerial perspective per vertex, interpolated,
// instead of per pixel (common/terrain_fragment.glsl finish). The haze changes slowly over a
// triangle (near, it is thin; far, the triangles are small): the same frames within a level.
#include "common/atmosphere.glsl"
#if defined TERRAIN_VERTEX_HAZE && TERRAIN_VERTEX_HAZE
uniform vec3 u_camera_pos;
out vec3 v_haze_transmittance;
out vec3 v_haze_inscatter;
#endif

void main() {
    v_world = in_position;
#if defined TERRAIN_VERTEX_HAZE && TERRAIN_VERTEX_HAZE
    haze(in_position, u_camera_pos, v_haze_transmittance, v_haze_inscatter);
#endif
    v_normal = in_normal;
#ifdef TERRAIN_TANGENTS
    v_tangent = in_tangent;
#endif
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
#endif

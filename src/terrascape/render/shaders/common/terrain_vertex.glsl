// Vertex stage shared by every terrain technique.
// Attributes come from terrascape.mesh.terrain_mesh: world position, unit normal and the
// tangent frame (seed 000 §2.5) as tangent.xyz + handedness w, so B = w * cross(N, T).
in vec3 in_position;
in vec3 in_normal;
in vec4 in_tangent;

uniform mat4 u_view_proj;
uniform vec2 u_extent;     // world size (x, z) of the terrain
uniform float u_uv_scale;  // planar mapping repeats (seed 000 §2.6.4 makePlanarTextureMapping)

out vec3 v_world;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;    // planar texture coordinate, tiled u_uv_scale times over the terrain
out vec2 v_grid;  // (x / extent_x, z / extent_z) in [0, 1]: for maps aligned with the grid

void main() {
    v_world = in_position;
    v_normal = in_normal;
    v_tangent = in_tangent;
    v_grid = in_position.xz / u_extent;
    v_uv = v_grid * u_uv_scale;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}

// "bump": normal mapping (seed 000 §2.5 tangent space, R2 Phong). The tiled RGBA texture
// holds a tangent-space normal in RGB (x along +u, y along +v, z out of the surface;
// pack_normal_height); it is taken to world space with the per-vertex frame
//   n_world = T * n.x + B * n.y + N * n.z,   B = w * cross(N, T)
// and lit with I = ka*ia + kd*(L.N)*id + ks*(R.V)^alpha*is.
#define TERRAIN_TANGENTS
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
uniform sampler2D u_color_tex;
uniform sampler2D u_normal_height;
uniform float u_bump_strength;  // scales the tangent-space x/y (0 = vertex normal only)

void main() {
    vec3 N = normalize(v_normal);
    vec3 T = normalize(v_tangent.xyz - N * dot(N, v_tangent.xyz));
    vec3 B = v_tangent.w * cross(N, T);
    vec3 n = texture(u_normal_height, v_uv).xyz * 2.0 - 1.0;
    n.xy *= u_bump_strength;
    vec3 Nw = normalize(T * n.x + B * n.y + N * n.z);
    vec3 albedo = texture(u_color_tex, grid_texcoord(vec2(textureSize(u_color_tex, 0)))).rgb;
    vec3 color = u_lighting == 0 ? albedo : phong(albedo, Nw, normalize(u_sun_dir), view_dir());
    f_color = finish(color);
}
#endif

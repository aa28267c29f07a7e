// "bump": normal mapping (Janković 2010 §2.5 tangent space, Phong). The tiled RGBA texture
// holds a tangent-space normal in RGB (x along +u, y along +v, z out of the surface;
// pack_normal_height); it is taken to world space with the per-vertex frame
//   n_world = T * n.x + B * n.y + N * n.z,   B = w * cross(N, T)
// and lit with I = ka*ia + kd*(L.N)*id + ks*(R.V)^alpha*is. The normal map (a photo's
// detail normals, terrascape.texture.photo_materials) is hex-tiled (common/hextile.glsl):
// each hexagon's lookup is offset and rotated, its normal turned back, so no grid of seams.
#define TERRAIN_TANGENTS
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
#include "common/hextile.glsl"
uniform sampler2D u_color_tex;
uniform sampler2D u_normal_height;
uniform float u_bump_strength;  // scales the tangent-space x/y (0 = vertex normal only)

void main() {
    vec3 N = normalize(v_normal);
    vec3 T = normalize(v_tangent.xyz - N * dot(N, v_tangent.xyz));
    vec3 B = v_tangent.w * cross(N, T);
    // Offsets only (rotation 0): a user's directional normal map keeps its direction.
    HexTile t = hex_tile(v_uv, 0.0, 0u);
    vec4 a[3];
    hex_fetch(u_normal_height, t, a);
    vec3 hw = hex_blend_weights(t, vec3(a[0].a, a[1].a, a[2].a), 0.6, 7.0);
    vec2 nxy = hw.x * hex_unrotate(t, 0, a[0].xy * 2.0 - 1.0)
             + hw.y * hex_unrotate(t, 1, a[1].xy * 2.0 - 1.0)
             + hw.z * hex_unrotate(t, 2, a[2].xy * 2.0 - 1.0);
    vec3 n = vec3(nxy * u_bump_strength, hw.x * a[0].z + hw.y * a[1].z + hw.z * a[2].z);
    n.z = n.z * 2.0 - 1.0;
    vec3 Nw = normalize(T * n.x + B * n.y + N * n.z);
    vec3 albedo = texture(u_color_tex, grid_texcoord(vec2(textureSize(u_color_tex, 0)))).rgb;
    vec3 color = LIGHTING_MODE == 0 ? unlit(albedo) : phong(albedo, Nw, normalize(u_sun_dir), view_dir());
    f_color = finish(color);
}
#endif

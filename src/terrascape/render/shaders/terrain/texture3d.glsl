// "texture3d": seed 001 §3.1.2. The layer textures are stacked along the depth coordinate r
// of a 3D texture; linear filtering along r blends two neighbouring layers. r comes from
// terrascape.texture.layer_coordinate (one value per vertex, interpolated like the seed's
// per-vertex glTexCoord3f), the s/t coordinates tile over the terrain.
#if defined VERTEX_SHADER
#include "common/terrain_vertex.glsl"
#elif defined FRAGMENT_SHADER
#include "common/terrain_fragment.glsl"
uniform sampler3D u_layers;
uniform sampler2D u_layer_coord;
uniform float u_tile_size;

void main() {
    float r = texture(u_layer_coord, grid_texcoord(vec2(textureSize(u_layer_coord, 0)))).r;
    vec3 albedo = texture(u_layers, vec3(v_world.xz / u_tile_size, r)).rgb;
    f_color = finish(shade(albedo, normalize(v_normal)));
}
#endif

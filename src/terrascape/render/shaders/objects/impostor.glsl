// Far objects as impostors (terrascape.render.objects): a quad standing on the object's foot
// and turned about +Y toward the viewer, textured from an atlas of the mesh rendered from
// several directions around it once at start (albedo + coverage, and normals in the mesh's
// frame), premultiplied by coverage. The two atlas views nearest to the viewer's direction are cross-faded, and the
// normals lit like the mesh, so the switch from mesh to impostor keeps its colour.
// DEPTH_ONLY: the shadow-map pass, the quad turned toward the sun (u_facing.w = 0).
#if defined VERTEX_SHADER
in vec2 in_corner;  // x in [-1, 1] across, y in [0, 1] up
in vec4 in_place;   // xyz foot, w scale
in float in_yaw;
uniform mat4 u_view_proj;
uniform vec4 u_facing;      // (point, 1): face that point; (direction, 0): face along it
uniform float u_radius;     // the mesh's largest distance from its vertical axis
uniform vec2 u_y_range;     // the mesh's lowest and highest y
uniform float u_views;      // atlas views per mesh (columns)
out vec2 v_cell;            // position inside the atlas cell, [0, 1]²
flat out vec3 v_views;      // first view, second view, weight of the second
flat out vec2 v_yaw;        // (cos, sin) of the instance's yaw
#ifndef DEPTH_ONLY
out vec3 v_world;
flat out vec3 v_foot_r;     // foot x, z and the instance's radius
#endif

void main() {
    vec3 toward = u_facing.xyz - in_place.xyz * u_facing.w;
    vec2 h = toward.xz;
    h = dot(h, h) > 1e-12 ? normalize(h) : vec2(0.0, 1.0);
    float c = cos(in_yaw);
    float s = sin(in_yaw);
    // the viewing direction in the mesh's frame, and its angle around the mesh
    vec2 local = vec2(c * h.x - s * h.y, s * h.x + c * h.y);
    float f = mod(atan(local.x, local.y) / 6.28318531 * u_views + u_views, u_views);
    float k0 = floor(f);
    v_views = vec3(k0, mod(k0 + 1.0, u_views), f - k0);
    v_yaw = vec2(c, s);
    vec3 right = vec3(h.y, 0.0, -h.x);
    float scale = in_place.w;
    vec3 world = in_place.xyz + right * (in_corner.x * u_radius * scale)
               + vec3(0.0, mix(u_y_range.x, u_y_range.y, in_corner.y) * scale, 0.0);
    v_cell = vec2(in_corner.x * 0.5 + 0.5, in_corner.y);
#ifndef DEPTH_ONLY
    v_world = world;
    v_foot_r = vec3(in_place.xz, u_radius * scale);
#endif
    gl_Position = u_view_proj * vec4(world, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_atlas_color;   // linear albedo × coverage, alpha = coverage
uniform sampler2D u_atlas_normal;  // normal in the mesh's frame × coverage, w = coverage
uniform float u_atlas_row;         // this mesh's row of cells
uniform vec2 u_atlas_cells;        // (views, meshes)
in vec2 v_cell;
flat in vec3 v_views;
flat in vec2 v_yaw;

vec2 atlas_uv(float view) {
    return (vec2(view, u_atlas_row) + clamp(v_cell, 0.002, 0.998)) / u_atlas_cells;
}

#ifdef DEPTH_ONLY
void main() {
    float a = mix(texture(u_atlas_color, atlas_uv(v_views.x)).a,
                  texture(u_atlas_color, atlas_uv(v_views.y)).a, v_views.z);
    if (a < 0.5) {
        discard;
    }
}
#else
#include "objects/common/object_shading.glsl"
in vec3 v_world;
flat in vec3 v_foot_r;
out vec4 f_color;

void main() {
    vec4 a = texture(u_atlas_color, atlas_uv(v_views.x));
    vec4 b = texture(u_atlas_color, atlas_uv(v_views.y));
    vec4 albedo = mix(a, b, v_views.z);
    if (albedo.a < 0.5) {
        discard;
    }
    // premultiplied: dividing by the coverage gives the mean over the covered texels; the
    // mean normal is left unnormalised — the diffuse and sky terms are linear in N, so a
    // texel covering two faces is lit as their mean, not brighter
    vec4 nb = mix(texture(u_atlas_normal, atlas_uv(v_views.x)),
                  texture(u_atlas_normal, atlas_uv(v_views.y)), v_views.z);
    vec3 n = nb.xyz / nb.w;
    float c = v_yaw.x;
    float s = v_yaw.y;
    vec3 N = vec3(c * n.x + s * n.z, n.y, -s * n.x + c * n.z);
    // The quad is flat but the object is not: its shadow is looked up outside the object,
    // a radius toward the sun, so it is shadowed by other casters only (its own shading
    // comes from the baked normals).
    vec3 q = v_world + u_sun_dir * v_foot_r.z;
    f_color = shade_object(albedo.rgb / max(albedo.a, 1e-3), N, v_world, q, v_foot_r.xy);
}
#endif
#endif

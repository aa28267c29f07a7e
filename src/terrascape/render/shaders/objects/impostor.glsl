// Far objects as impostors (terrascape.render.objects): a quad through the middle of the
// object facing the viewer, textured from an atlas of the mesh rendered once from a
// hemisphere of directions — u_views around it at each of u_elevations elevations from the
// side (0°) to straight above (90°) — (albedo + coverage, and normals in the mesh's frame),
// premultiplied by coverage. The four atlas views around the viewer's direction (two
// around, two in elevation) are blended, each sampled where it saw the point the viewing
// ray meets (atlas_uv), and the normals lit like the mesh, so the switch from mesh to
// impostor keeps its outline and colour, seen from the side or from above.
// DEPTH_ONLY: the shadow-map pass, the quad facing the sun (u_facing.w = 0).
#if defined VERTEX_SHADER
in vec2 in_corner;  // x in [-1, 1] across, y in [0, 1] up
in vec4 in_place;   // xyz foot, w scale
in float in_yaw;
uniform mat4 u_view_proj;
uniform vec4 u_facing;      // (point, 1): face that point; (direction, 0): face along it
uniform float u_radius;     // the mesh's largest distance from its vertical axis
uniform vec2 u_up_range;    // the quad's extent along its up axis (mesh units)
uniform float u_mid;        // height of the middle of the mesh's bounding sphere
uniform float u_views;      // atlas views per elevation (columns)
uniform float u_elevations; // atlas elevations per mesh (rows), 0° … 90°
out vec3 v_local;           // the quad's point in the mesh's frame (mesh units) ...
out vec3 v_ray;             // ... and the viewing ray's direction there (not normalised)
flat out vec3 v_views;      // first view, second view, weight of the second
flat out vec3 v_rows;       // lower elevation row, upper row, weight of the upper
flat out vec2 v_yaw;        // (cos, sin) of the instance's yaw
#ifndef DEPTH_ONLY
out vec3 v_world;
flat out vec3 v_foot_r;     // foot x, z and the instance's radius
#endif

void main() {
    float scale = in_place.w;
    vec3 centre = in_place.xyz + vec3(0.0, u_mid * scale, 0.0);
    vec3 toward = u_facing.xyz - centre * u_facing.w;
    vec3 d = dot(toward, toward) > 1e-12 ? normalize(toward) : vec3(0.0, 1.0, 0.0);
    // seen from below the horizon: the side view (the atlas holds the upper hemisphere)
    if (d.y < 0.0) {
        d = vec3(d.x, 0.0, d.z);
        d = dot(d, d) > 1e-12 ? normalize(d) : vec3(0.0, 0.0, 1.0);
    }
    vec2 h = d.xz;
    // straight above: any horizontal frame will do, the views differ by a turn only
    h = dot(h, h) > 1e-12 ? normalize(h) : vec2(0.0, 1.0);
    float c = cos(in_yaw);
    float s = sin(in_yaw);
    // the viewing direction in the mesh's frame: its angle around the mesh ...
    vec2 local = vec2(c * h.x - s * h.y, s * h.x + c * h.y);
    float f = mod(atan(local.x, local.y) / 6.28318531 * u_views + u_views, u_views);
    float k0 = floor(f);
    v_views = vec3(k0, mod(k0 + 1.0, u_views), f - k0);
    // ... and its elevation, between two rows of views
    float e = clamp(asin(clamp(d.y, 0.0, 1.0)) / 1.57079633, 0.0, 1.0) * (u_elevations - 1.0);
    float e0 = min(floor(e), u_elevations - 2.0);
    v_rows = vec3(e0, e0 + 1.0, e - e0);
    v_yaw = vec2(c, s);
    // the quad's frame is the atlas views': x along the horizontal right, up = d × right.
    // Seen by the viewer it lies in the plane through the middle of the bounding sphere (from
    // above, a plane through the foot would sink into the ground around it); seen from the
    // sun, in the plane through the foot: the shadow it casts is the same (the plane only
    // moves along the light), but every point of the object's own sunward side then lies
    // in front of it, not under its own impostor's shadow. At 0° both are the vertical quad
    // through the object's axis.
    vec3 right = vec3(h.y, 0.0, -h.x);
    vec3 up = cross(d, right);
    float x = in_corner.x * u_radius;
    float u = mix(u_up_range.x, u_up_range.y, in_corner.y);
#ifdef DEPTH_ONLY
    float along = 0.0;
#else
    float along = u_mid * d.y;
#endif
    vec3 world = in_place.xyz + scale * (right * x + up * u + d * along);
    // into the mesh's frame (the inverse of objects/mesh.glsl's transform): the fragment
    // stage finds where each atlas view saw the point the viewing ray passes through
    vec3 rel = (world - in_place.xyz) / scale;
    v_local = vec3(c * rel.x - s * rel.z, rel.y, s * rel.x + c * rel.z);
    vec3 ray = u_facing.w > 0.5 ? world - u_facing.xyz : -u_facing.xyz;
    v_ray = vec3(c * ray.x - s * ray.z, ray.y, s * ray.x + c * ray.z);
#ifndef DEPTH_ONLY
    v_world = world;
    v_foot_r = vec3(in_place.xz, u_radius * scale);
#endif
    gl_Position = u_view_proj * vec4(world, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_atlas_color;   // linear albedo × coverage, alpha = coverage
uniform sampler2D u_atlas_normal;  // normal in the mesh's frame × coverage, w = coverage
uniform float u_atlas_row;         // this mesh's first row of cells (elevation 0°)
uniform vec2 u_atlas_cells;        // (views, meshes × elevations)
uniform float u_views;
uniform float u_elevations;
uniform float u_radius;
uniform vec2 u_up_range;
uniform float u_mid;
in vec3 v_local;
in vec3 v_ray;
flat in vec3 v_views;
flat in vec3 v_rows;
flat in vec2 v_yaw;

// Where atlas view (view, row) saw the point of the object the viewing ray meets: the ray
// cut with that view's plane through the middle of the mesh, in the view's orthographic
// frame (objects.py _bake_matrix). Each view is sampled where it holds the same point,
// not at the quad's own coordinates: two views a turn apart (all views from straight
// above differ by one) then line up instead of showing the object twice, turned — a
// house seen from above as a blur of two rotated roofs.
vec2 atlas_uv(float view, float row) {
    float phi = 6.28318531 * view / u_views;
    float el = 1.57079633 * row / (u_elevations - 1.0);
    vec3 d = vec3(sin(phi) * cos(el), sin(el), cos(phi) * cos(el));
    vec3 right = vec3(cos(phi), 0.0, -sin(phi));
    vec3 up = cross(d, right);
    vec3 o = v_local - vec3(0.0, u_mid, 0.0);
    float along = dot(v_ray, d);
    vec3 p = abs(along) > 1e-6 * length(v_ray) ? o - v_ray * (dot(o, d) / along) : o;
    vec2 cell = vec2(0.5 + 0.5 * dot(right, p) / u_radius,
                     (dot(up, p) + u_mid * up.y - u_up_range.x) / (u_up_range.y - u_up_range.x));
    return (vec2(view, u_atlas_row + row) + clamp(cell, 0.002, 0.998)) / u_atlas_cells;
}

// The atlas blended over the four views around the viewing direction.
vec4 atlas(sampler2D tex) {
    vec4 lower = mix(texture(tex, atlas_uv(v_views.x, v_rows.x)),
                     texture(tex, atlas_uv(v_views.y, v_rows.x)), v_views.z);
    vec4 upper = mix(texture(tex, atlas_uv(v_views.x, v_rows.y)),
                     texture(tex, atlas_uv(v_views.y, v_rows.y)), v_views.z);
    return mix(lower, upper, v_rows.z);
}

#ifdef DEPTH_ONLY
void main() {
    if (atlas(u_atlas_color).a < 0.5) {
        discard;
    }
}
#else
#include "objects/common/object_shading.glsl"
in vec3 v_world;
flat in vec3 v_foot_r;
out vec4 f_color;

void main() {
    vec4 albedo = atlas(u_atlas_color);
    if (albedo.a < 0.5) {
        discard;
    }
    // premultiplied: dividing by the coverage gives the mean over the covered texels; the
    // mean normal is left unnormalised — the diffuse and sky terms are linear in N, so a
    // texel covering two faces is lit as their mean, not brighter
    vec4 nb = atlas(u_atlas_normal);
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

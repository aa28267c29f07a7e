// Far objects as impostors (terrascape.render.objects): a quad through the middle of the
// object facing the viewer, textured from an atlas of the mesh rendered once from a
// hemisphere of directions — u_views around it at each of u_elevations elevations from the
// side (0°) to straight above (90°) — (albedo + coverage, and normals in the mesh's frame),
// premultiplied by coverage. The four atlas views around the viewer's direction (two
// around, two in elevation) are blended — seen from above each sampled where it saw the
// point the viewing ray meets (view_cell) — and the normals lit like the mesh, so the
// switch from mesh to impostor keeps its outline and colour, seen from the side or from
// above.
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
// Where each of the four blended atlas views saw the point the viewing ray meets, as
// homogeneous cell coordinates (x·w, y·w, w): linear over the quad, so interpolated
// exactly; the fragment stage divides (atlas_uv).
out vec3 v_cell00;          // (first view, lower row)
out vec3 v_cell10;          // (second view, lower row)
out vec3 v_cell01;          // (first view, upper row)
out vec3 v_cell11;          // (second view, upper row)
out vec2 v_cell;            // the quad's own position inside a cell, [0, 1]²
flat out float v_reproject; // weight of the reprojected cells against v_cell
flat out vec3 v_views;      // first view, second view, weight of the second
flat out vec3 v_rows;       // lower elevation row, upper row, weight of the upper
flat out vec2 v_yaw;        // (cos, sin) of the instance's yaw
#ifndef DEPTH_ONLY
out vec3 v_world;
flat out vec3 v_foot_r;     // foot x, z and the instance's radius
#endif

// The mesh-frame point q (relative to the middle of the mesh) as atlas view (view, row)
// saw the point its ray meets: the ray cut with that view's plane through the middle, in
// the view's orthographic frame (objects.py _bake_matrix) — homogeneous, see v_cell00.
// The ray comes from eye e (mesh frame, relative to the middle) or, with directional,
// runs along -e.
vec3 view_cell(float view, float row, vec3 q, vec3 e, bool directional) {
    float phi = 6.28318531 * view / u_views;
    float el = 1.57079633 * row / (u_elevations - 1.0);
    vec3 d = vec3(sin(phi) * cos(el), sin(el), cos(phi) * cos(el));
    vec3 right = vec3(cos(phi), 0.0, -sin(phi));
    vec3 up = cross(d, right);
    float w;
    vec3 p;
    if (directional) {  // p = q + e·t on the plane: (q·w − e·(q·d)) / w, w = e·d
        w = dot(e, d);
        p = q * w - e * dot(q, d);
    } else {            // p = e + (q − e)·t on the plane: (e·w − (q − e)·(e·d)) / w
        w = dot(q - e, d);
        p = e * w - (q - e) * dot(e, d);
    }
    return vec3(0.5 * w + 0.5 * dot(right, p) / u_radius,
                (dot(up, p) + (u_mid * up.y - u_up_range.x) * w)
                    / (u_up_range.y - u_up_range.x),
                w);
}

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
    // into the mesh's frame (the inverse of objects/mesh.glsl's transform), relative to
    // its middle: where each blended view saw the point the viewing ray passes through
    vec3 rel = (world - in_place.xyz) / scale;
    vec3 q = vec3(c * rel.x - s * rel.z, rel.y - u_mid, s * rel.x + c * rel.z);
    bool directional = u_facing.w < 0.5;
    vec3 eye = directional ? u_facing.xyz : (u_facing.xyz - in_place.xyz) / scale;
    eye = vec3(c * eye.x - s * eye.z, eye.y - (directional ? 0.0 : u_mid),
               s * eye.x + c * eye.z);
    v_cell = vec2(in_corner.x * 0.5 + 0.5, in_corner.y);
    // From the side the views differ by how the object turns (the quad's own cell position
    // serves), from above by a turn of the whole image: reprojected cells from 40° up,
    // only them above 70°.
    v_reproject = smoothstep(0.6981317, 1.2217305, asin(clamp(d.y, 0.0, 1.0)));
    v_cell00 = view_cell(v_views.x, v_rows.x, q, eye, directional);
    v_cell10 = view_cell(v_views.y, v_rows.x, q, eye, directional);
    v_cell01 = view_cell(v_views.x, v_rows.y, q, eye, directional);
    v_cell11 = view_cell(v_views.y, v_rows.y, q, eye, directional);
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
in vec3 v_cell00;
in vec3 v_cell10;
in vec3 v_cell01;
in vec3 v_cell11;
in vec2 v_cell;
flat in float v_reproject;
flat in vec3 v_views;
flat in vec3 v_rows;
flat in vec2 v_yaw;

// Seen from above, each view sampled where it holds the same point of the object, not at
// the quad's own coordinates: two views a turn apart (all views from straight above differ
// by one) then line up instead of showing the object twice, turned — a house from above as
// a blur of two rotated roofs.
vec2 atlas_uv(float view, float row, vec3 h) {
    vec2 cell = v_cell;
    if (v_reproject > 0.0) {
        cell = mix(v_cell, abs(h.z) > 1e-12 ? h.xy / h.z : v_cell, v_reproject);
    }
    return (vec2(view, u_atlas_row + row) + clamp(cell, 0.002, 0.998)) / u_atlas_cells;
}

// The atlas blended over the four views around the viewing direction.
vec4 atlas(sampler2D tex) {
    vec4 lower = mix(texture(tex, atlas_uv(v_views.x, v_rows.x, v_cell00)),
                     texture(tex, atlas_uv(v_views.y, v_rows.x, v_cell10)), v_views.z);
    vec4 upper = mix(texture(tex, atlas_uv(v_views.x, v_rows.y, v_cell01)),
                     texture(tex, atlas_uv(v_views.y, v_rows.y, v_cell11)), v_views.z);
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

// Small-triangle culling for software rasterisers (the terrain renderer's geometry stage,
// used on full-resolution chunks whose cells project to less than a pixel).
//
// A 1025² terrain seen whole puts 2 M triangles of ~0.1 px² on a 1280×720 image; llvmpipe
// sets up and bins every one of them on a single thread, though about 70 % contain no pixel
// centre and so produce no fragment. A triangle whose screen bounding box holds no pixel
// centre (k + 0.5) in x or in y cannot cover one (GL's rasterisation samples pixel
// centres only, single-sampled), so dropping it here leaves the image as it was. The test
// keeps every triangle within 1/64 px of a centre (llvmpipe snaps to 1/256 px) and every
// triangle with a vertex at or behind the eye plane (w <= 0), which the clipper handles.
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

in vec3 g_world[];
in vec3 g_normal[];
out vec3 v_world;
out vec3 v_normal;
#ifdef TERRAIN_TANGENTS
in vec4 g_tangent[];
out vec4 v_tangent;
#endif

uniform vec2 u_viewport_size;   // framebuffer width, height in pixels

bool holds_no_pixel_centre(vec4 p0, vec4 p1, vec4 p2) {
    if (min(min(p0.w, p1.w), p2.w) <= 0.0) {
        return false;
    }
    vec2 half_size = 0.5 * u_viewport_size;
    vec2 s0 = p0.xy / p0.w * half_size + half_size;
    vec2 s1 = p1.xy / p1.w * half_size + half_size;
    vec2 s2 = p2.xy / p2.w * half_size + half_size;
    // centres k + 0.5 inside [lo, hi] <=> ceil(lo - 0.5) <= floor(hi - 0.5)
    vec2 lo = ceil(min(min(s0, s1), s2) - (0.5 + 1.0 / 64.0));
    vec2 hi = floor(max(max(s0, s1), s2) - (0.5 - 1.0 / 64.0));
    return any(greaterThan(lo, hi));
}

void main() {
    if (holds_no_pixel_centre(gl_in[0].gl_Position, gl_in[1].gl_Position,
                              gl_in[2].gl_Position)) {
        return;
    }
    for (int i = 0; i < 3; ++i) {
        gl_Position = gl_in[i].gl_Position;
        v_world = g_world[i];
        v_normal = g_normal[i];
#ifdef TERRAIN_TANGENTS
        v_tangent = g_tangent[i];
#endif
        EmitVertex();
    }
    EndPrimitive();
}

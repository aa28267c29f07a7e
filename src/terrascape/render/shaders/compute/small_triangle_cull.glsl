// Small-triangle culling for software rasterisers, run per frame on each full-resolution
// chunk whose cells project to under a pixel (terrascape.render.terrain).
//
// Why: a 1025² terrain seen whole puts 2 M triangles of ~0.1 px² on a 1280×720 image, and
// llvmpipe sets up and bins every one of them on its single front-end thread, though ~70 %
// hold no pixel centre and so draw nothing. GL rasterisation (single-sampled) samples pixel
// centres (k + 0.5) only, so a triangle whose screen bounding box holds no centre in x or in
// y - or none inside the viewport - cannot produce a fragment: dropping it leaves the image
// as it was (small-primitive culling, Wihlidal, "Optimizing the Graphics Pipeline with
// Compute", GDC 2016). This pass runs on llvmpipe's compute threads (both cores) and
// rewrites the chunk's index buffer, replacing each such triangle by a degenerate one
// (i, i, i), which the rasteriser rejects after a few instructions instead of a full setup.
// Triangle order, hence vertex-cache reuse and the image, is kept.
//
// Input: the chunk's vertex positions (x, y, z floats, the vertex buffer itself) and its
// size; the triangles are the band order of terrascape.mesh.banded_grid_triangles:
// bands of u_band quad rows, each band column by column, quad (r, c) = triangles
// (i00, i10, i01), (i01, i10, i11) with i00 = r·cols + c. One invocation per quad writes
// its six 16-bit indices as three words. Within 1/64 px of a centre a triangle is kept
// (llvmpipe snaps vertices to 1/256 px); a quad with a vertex at or behind the eye plane
// (w <= 0) is kept whole for the clipper.
#if defined COMPUTE_SHADER
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Positions { float positions[]; };
layout(std430, binding = 1) writeonly buffer Indices { uint indices[]; };

uniform mat4 u_view_proj;
uniform vec2 u_viewport_size;   // pixels
uniform uint u_rows;            // chunk vertices per column
uniform uint u_cols;            // chunk vertices per row
uniform uint u_band;            // quad rows per band

const float MARGIN_PX = 1.0 / 64.0;

vec2 to_screen(uint i, inout bool behind) {
    vec4 p = u_view_proj * vec4(positions[3u * i], positions[3u * i + 1u],
                                positions[3u * i + 2u], 1.0);
    behind = behind || p.w <= 0.0;
    vec2 half_size = 0.5 * u_viewport_size;
    return p.xy / p.w * half_size + half_size;
}

// Some pixel centre k + 0.5 of the viewport lies in the box of (s0, s1, s2)?
bool box_holds_centre(vec2 s0, vec2 s1, vec2 s2) {
    vec2 lo = max(min(min(s0, s1), s2), vec2(0.0));
    vec2 hi = min(max(max(s0, s1), s2), u_viewport_size);
    return all(lessThanEqual(ceil(lo - (0.5 + MARGIN_PX)), floor(hi - (0.5 - MARGIN_PX))));
}

void main() {
    uint quad = gl_GlobalInvocationID.x;
    uint quads_per_band = u_band * (u_cols - 1u);
    if (quad >= (u_rows - 1u) * (u_cols - 1u)) {
        return;
    }
    // quad number -> (row, col) in band order; every band before this one is full
    uint band = quad / quads_per_band;
    uint row0 = band * u_band;
    uint band_rows = min(u_band, u_rows - 1u - row0);
    uint k = quad - band * quads_per_band;
    uint col = k / band_rows;
    uint row = row0 + k % band_rows;
    uint i00 = row * u_cols + col;
    uint i01 = i00 + 1u;
    uint i10 = i00 + u_cols;
    uint i11 = i10 + 1u;
    bool behind = false;
    vec2 s00 = to_screen(i00, behind);
    vec2 s01 = to_screen(i01, behind);
    vec2 s10 = to_screen(i10, behind);
    vec2 s11 = to_screen(i11, behind);
    uint a1 = i10, a2 = i01, b1 = i10, b2 = i11;
    if (!behind) {
        if (!box_holds_centre(s00, s10, s01)) {
            a1 = i00;
            a2 = i00;
        }
        if (!box_holds_centre(s01, s10, s11)) {
            b1 = i01;
            b2 = i01;
        }
    }
    // (i00, a1, a2), (i01, b1, b2) as 16-bit indices, two per word, low half first
    uint word = 3u * quad;
    indices[word] = i00 | (a1 << 16);
    indices[word + 1u] = a2 | (i01 << 16);
    indices[word + 2u] = b1 | (b2 << 16);
}
#endif

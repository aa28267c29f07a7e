// Hex-tiling (Mikkelsen 2022, "Practical Real-Time Hex-Tiling", JCGT 11(3); after Heitz &
// Neyret 2018): a texture sampled without a visible period. The plane is covered by a
// triangle grid; each grid vertex (a hexagon's centre) has its own random offset and rotation
// into the texture, and a point blends its triangle's three lookups with barycentric weights
// ^ u_hex_sharpness, modulated by each lookup's luminance/height (u_hex_contrast).
// The same grid, PCG2D hash and weights as terrascape.texture.hextile (CPU).
//
// Use: HexTile t = hex_tile(uv, rotation, seed); then per texture
//   vec4 a[3]; hex_fetch_array(tex, layer, t, a);   // three lookups, one mip level
//   vec3 w = hex_blend_weights(t, vec3(a[0].a, a[1].a, a[2].a), contrast, sharpness);
//   vec4 c = w.x * a[0] + w.y * a[1] + w.z * a[2];
// Tangent-space normals fetched this way must be rotated back: hex_unrotate(t, k, n.xy).

const float HEX_SCALE = 3.46410162;  // 2·sqrt(3): triangle-grid cells per texture unit

struct HexTile {
    vec2 uv[3];     // texture coordinates seen from the three vertices
    vec2 cs[3];     // (cos, sin) of each vertex's rotation
    vec3 w;         // barycentric weights
    vec2 dx;        // screen derivatives of the unrotated uv (hex_lod)
    vec2 dy;
};

uvec2 pcg2d(uvec2 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * 1664525u;
    v.y += v.x * 1664525u;
    v = v ^ (v >> 16u);
    v.x += v.y * 1664525u;
    v.y += v.x * 1664525u;
    v = v ^ (v >> 16u);
    return v;
}

void hex_vertex(ivec2 vert, vec2 uv, float rotation, uint seed, out vec2 st, out vec2 cs) {
    vec2 centre = vec2(float(vert.x), 0.5 * float(vert.x) + 0.8660254 * float(vert.y))
        / HEX_SCALE;
    uvec2 h = pcg2d(uvec2(vert) + uvec2(seed * 7919u, seed * 104729u));
    vec2 offset = vec2(h) / 4294967296.0;
    float angle = (float(pcg2d(h).x) / 4294967296.0 * 2.0 - 1.0) * 3.14159265 * rotation;
    cs = vec2(cos(angle), sin(angle));
    vec2 d = uv - centre;
    st = vec2(cs.x * d.x - cs.y * d.y, cs.y * d.x + cs.x * d.y) + centre + offset;
}

HexTile hex_tile(vec2 uv, float rotation, uint seed) {
    HexTile t;
    t.dx = dFdx(uv);
    t.dy = dFdy(uv);
    vec2 p = uv * HEX_SCALE;
    vec2 skewed = vec2(p.x, -0.57735027 * p.x + 1.15470054 * p.y);
    vec2 base = floor(skewed);
    vec2 f = skewed - base;
    float fz = 1.0 - f.x - f.y;
    float s = fz < 0.0 ? 1.0 : 0.0;
    float s2 = 2.0 * s - 1.0;
    t.w = vec3(-fz * s2, s - f.y * s2, s - f.x * s2);
    ivec2 b = ivec2(base);
    int si = int(s);
    hex_vertex(b + ivec2(si, si), uv, rotation, seed, t.uv[0], t.cs[0]);
    hex_vertex(b + ivec2(si, 1 - si), uv, rotation, seed, t.uv[1], t.cs[1]);
    hex_vertex(b + ivec2(1 - si, si), uv, rotation, seed, t.uv[2], t.cs[2]);
    return t;
}

vec2 hex_rotate(vec2 cs, vec2 d) {
    return vec2(cs.x * d.x - cs.y * d.y, cs.y * d.x + cs.x * d.y);
}

// The mip level of the unrotated mapping on a texture of `size` texels (GL's isotropic
// λ = log2 ρ). A rotation keeps the derivatives' lengths, so the three rotated lookups share
// it: no seams at hexagon edges, and one level per pixel instead of one per lookup
// (textureGrad with the rotated derivatives selects the same level).
float hex_lod(HexTile t, vec2 size) {
    return log2(max(length(t.dx * size), length(t.dy * size)));
}

// Three lookups of layer `layer` of a texture array at the unrotated mapping's mip level.
// HEX_GRAD_PER_LOOKUP (a define; `terrascape bench terrain_shading`'s reference): each
// lookup takes its rotated derivatives (textureGrad), the level chosen per lookup.
void hex_fetch_array(sampler2DArray tex, float layer, HexTile t, out vec4 a[3]) {
#ifdef HEX_GRAD_PER_LOOKUP
    for (int k = 0; k < 3; ++k) {
        a[k] = textureGrad(tex, vec3(t.uv[k], layer), hex_rotate(t.cs[k], t.dx),
                           hex_rotate(t.cs[k], t.dy));
    }
    return;
#endif
    float lod = hex_lod(t, vec2(textureSize(tex, 0).xy));
    for (int k = 0; k < 3; ++k) {
        a[k] = textureLod(tex, vec3(t.uv[k], layer), lod);
    }
}

void hex_fetch(sampler2D tex, HexTile t, out vec4 a[3]) {
#ifdef HEX_GRAD_PER_LOOKUP
    for (int k = 0; k < 3; ++k) {
        a[k] = textureGrad(tex, t.uv[k], hex_rotate(t.cs[k], t.dx), hex_rotate(t.cs[k], t.dy));
    }
    return;
#endif
    float lod = hex_lod(t, vec2(textureSize(tex, 0)));
    for (int k = 0; k < 3; ++k) {
        a[k] = textureLod(tex, t.uv[k], lod);
    }
}

// Mikkelsen's weights: mix(1, lum, contrast) · w^sharpness, normalised.
vec3 hex_blend_weights(HexTile t, vec3 lum, float contrast, float sharpness) {
    vec3 w = mix(vec3(1.0), lum, contrast) * pow(max(t.w, vec3(0.0)), vec3(sharpness));
    float total = w.x + w.y + w.z;
    return total > 0.0 ? w / total : vec3(1.0 / 3.0);
}

// A tangent-space normal's xy fetched through vertex k's rotation, in the unrotated frame:
// the texture's gradient turns with the lookup, so n_uv.xy = R^T n_tex.xy.
vec2 hex_unrotate(HexTile t, int k, vec2 nxy) {
    vec2 cs = t.cs[k];
    return vec2(cs.x * nxy.x + cs.y * nxy.y, -cs.y * nxy.x + cs.x * nxy.y);
}

// Fragment-stage helpers shared by every terrain technique: inputs, lighting mode, fog.
#include "common/lighting.glsl"
#include "common/atmosphere.glsl"
#include "common/fog.glsl"
#include "common/cascades.glsl"

#ifdef DEFERRED
// Deferred shading (terrascape.render.terrain: full-resolution frames of sub-pixel
// triangles on a software rasteriser). A first pass (terrain/gbuffer.glsl) stores each
// pixel's interpolated surface attributes; this pass runs the technique's shading once per
// pixel from them. A CPU rasteriser shades a tiny triangle's covered pixel with a whole
// SIMD vector of lanes; shading full-screen runs every lane on a pixel of its own.
uniform sampler2D u_gbuffer_world;    // xyz world position (w = 1 where terrain was drawn)
uniform sampler2D u_gbuffer_normal;   // xyz interpolated vertex normal
vec3 v_world;
vec3 v_normal;
#ifdef TERRAIN_TANGENTS
#ifdef TERRAIN_HEIGHTFIELD_TANGENTS
// The tangent frame rebuilt from the normal (a technique's define): every terrain mesh
// (terrascape.mesh.heightfield_tangent_frames, the world's tiles, the renderer's skirts)
// makes its tangents from its normals, so the geometry pass need not store them — four
// fewer interpolated values per triangle and one attachment less to write and read.
vec4 heightfield_tangent(vec3 n) {
    // the skirts: horizontal normals, T = N × up, handedness +1
    if (abs(n.y) < 1e-4) return vec4(-n.z, 0.0, n.x, 1.0);
    // the surface: T ∝ ∂P/∂x = (1, ∂h/∂x, 0) with N ∝ (-∂h/∂x, 1, -∂h/∂z), handedness -1
    return vec4(normalize(vec3(n.y, -n.x, 0.0)), -1.0);
}
#else
uniform sampler2D u_gbuffer_tangent;  // interpolated tangent.xyz + handedness w
#endif
vec4 v_tangent;
#endif
void technique_main();
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 world = texelFetch(u_gbuffer_world, p, 0);
    // A lane without terrain (shaded only as a neighbour for derivatives, its colour is
    // rejected by the depth test) takes a terrain pixel of its 2×2 quad, so the technique's
    // derivatives at the terrain's edge stay those of the surface instead of a jump to 0.
    for (int k = 1; k <= 3 && world.w == 0.0; ++k) {
        ivec2 q = p ^ ivec2(k & 1, k >> 1);
        vec4 other = texelFetch(u_gbuffer_world, q, 0);
        if (other.w != 0.0) {
            p = q;
            world = other;
        }
    }
    v_world = world.xyz;
    v_normal = texelFetch(u_gbuffer_normal, p, 0).xyz;
#ifdef TERRAIN_TANGENTS
#ifdef TERRAIN_HEIGHTFIELD_TANGENTS
    v_tangent = heightfield_tangent(v_normal);
#else
    v_tangent = texelFetch(u_gbuffer_tangent, p, 0);
#endif
#endif
    // Pixels without terrain were rejected by the depth test (the renderer copies the
    // geometry pass's depth first and draws this pass at depth 1 with GL_GREATER), so the
    // early depth test skips whole blocks of sky before any shading.
    technique_main();
}
#define main technique_main
#else
in vec3 v_world;
in vec3 v_normal;
#ifdef TERRAIN_TANGENTS
in vec4 v_tangent;
#endif
#endif

uniform vec2 u_extent;     // world size (x, z) of the terrain
uniform float u_uv_scale;  // planar mapping repeats (Janković 2010 §2.6.4 makePlanarTextureMapping)

// Planar texture coordinates from the interpolated world position: the same values as
// interpolating them (they are linear in position) without two more varyings.
// v_grid = (x / extent_x, z / extent_z) in [0, 1], for maps aligned with the grid;
// v_uv = v_grid tiled u_uv_scale times over the terrain.
#define v_grid (v_world.xz / u_extent)
#define v_uv (v_grid * u_uv_scale)

out vec4 f_color;

uniform vec3 u_camera_pos;
uniform float u_exaggeration;
uniform int u_lighting;          // 0 none, 1 Phong with the given normal, 2 lightmap, 3 daylight
// TERRAIN_LIGHTING and TERRAIN_CASCADES: #defines each program is compiled with (the frame's
// lighting mode; whether the objects' shadow cascades are read). A software rasteriser runs
// every branch of a shader on every pixel, so the lighting modes a frame does not use and an
// unused cascade lookup would cost every terrain pixel (a third of a plain daylight frame on
// llvmpipe). Without the defines the uniforms u_lighting / u_cascade_count decide, as before.
#ifdef TERRAIN_LIGHTING
#define LIGHTING_MODE TERRAIN_LIGHTING
#else
#define LIGHTING_MODE u_lighting
#endif
#ifndef TERRAIN_CASCADES
#define TERRAIN_CASCADES 1
#endif
uniform sampler2D u_lightmap;    // one value per vertex (terrascape.lighting.lightmap)
uniform float u_lightmap_ambient;  // its value in shadow
// Daylight: per vertex, R = visible share of the sun's disc (soft cast shadows from the
// terrain, terrascape.lighting.soft_shadow), G = sky-view factor; sampled bilinearly per
// fragment, so shadow edges are as smooth as the penumbra, not the triangles.
uniform sampler2D u_sun_sky;

// Texture coordinate of a texture whose texel (i, j) belongs to vertex (i, j) (region
// texture, lightmap, splat maps): texel centres sit at (k + 0.5) / size, corners aligned.
vec2 grid_texcoord(vec2 size) {
    return (v_grid * (size - 1.0) + 0.5) / size;
}

#ifdef TERRAIN_SURFACE_NORMALS
uniform sampler2D u_surface_normal;  // vertex normals as 0.5 + 0.5·n (RGB8), one texel each
#endif

// The surface's unit normal at this fragment. With TERRAIN_SURFACE_NORMALS (a technique's
// define): the vertex normals filtered per pixel with a cubic B-spline over the grid
// (four bilinear taps at shifted positions, Sigg & Hadwiger 2005), a normal field smooth
// across cells and vertices — close up, a coarse grid's triangles otherwise show as
// facets lit flat along their edges and diagonals. The skirts (exactly horizontal normals,
// at the border) keep their own.
vec3 surface_normal() {
#ifdef TERRAIN_SURFACE_NORMALS
    vec2 size = vec2(textureSize(u_surface_normal, 0));
    vec2 t = v_grid * (size - 1.0);          // texel index space (texel k at k)
    vec2 i = floor(t);
    vec2 f = t - i;
    vec2 f2 = f * f;
    vec2 f3 = f2 * f;
    vec2 w0 = (1.0 - 3.0 * f + 3.0 * f2 - f3) / 6.0;
    vec2 w1 = (4.0 - 6.0 * f2 + 3.0 * f3) / 6.0;
    vec2 w3 = f3 / 6.0;
    vec2 g0 = w0 + w1;
    vec2 g1 = 1.0 - g0;
    vec2 h0 = (i - 1.0 + w1 / g0 + 0.5) / size;
    vec2 h1 = (i + 1.0 + w3 / g1 + 0.5) / size;
    vec3 n = g0.y * (g0.x * texture(u_surface_normal, h0).rgb
                     + g1.x * texture(u_surface_normal, vec2(h1.x, h0.y)).rgb)
           + g1.y * (g0.x * texture(u_surface_normal, vec2(h0.x, h1.y)).rgb
                     + g1.x * texture(u_surface_normal, h1).rgb);
    n = n * 2.0 - 1.0;
    return normalize(abs(v_normal.y) < 1e-4 ? v_normal : n);
#else
    return normalize(v_normal);
#endif
}

vec3 view_dir() {
    return normalize(u_camera_pos - v_world);
}

// (sun visibility, sky visibility) of this fragment; with objects on the terrain, the
// shadows of the sun's cascades too (the darker of the two: both see the terrain).
vec2 sun_sky_visibility() {
    vec2 vis = texture(u_sun_sky, grid_texcoord(vec2(textureSize(u_sun_sky, 0)))).rg;
#if TERRAIN_CASCADES
    if (u_cascade_count > 0) {
        vis.x = min(vis.x, cascade_sun_visibility(v_world, normalize(v_normal), 0.0));
    }
#endif
    return vis;
}

// Visible share of the sun past the objects alone (their shadow cascades; 1 without
// objects): the lighting modes other than daylight take the terrain's own shadows from
// their lightmap or not at all, and the objects' from here.
float object_sun_visibility() {
#if TERRAIN_CASCADES
    if (u_cascade_count > 0) {
        return cascade_sun_visibility(v_world, normalize(v_normal), 0.0);
    }
#endif
    return 1.0;
}

// Colour of a surface point with albedo and unit normal N under the chosen lighting mode.
// Daylight returns linear radiance (the albedo is sRGB-decoded); finish() displays it.
vec3 shade(vec3 albedo, vec3 N) {
    if (LIGHTING_MODE == 3) {
        vec2 vis = sun_sky_visibility();
        return daylight_radiance(srgb_to_linear(albedo), N, vis.x, vis.y);
    }
    if (LIGHTING_MODE == 1) {
        return phong_sun(albedo, N, normalize(u_sun_dir), view_dir(), object_sun_visibility());
    }
    if (LIGHTING_MODE == 2) {
        if (u_sun_blocked != 0) {  // in an object's shadow: what the lightmap has in shade
            return albedo * u_lightmap_ambient;
        }
        vec2 uv = grid_texcoord(vec2(textureSize(u_lightmap, 0)));
        float light = texture(u_lightmap, uv).r;
        // in an object's cascaded shadow: the same shade, never brighter than the lightmap
        float shaded = min(light, u_lightmap_ambient);
        return albedo * mix(shaded, light, object_sun_visibility());
    }
    return unlit_sun(albedo, object_sun_visibility());
}

// Techniques that light with phong() themselves (bump, relief) get the daylight model too
// when it is on: diffuse daylight with the cast shadows, plus their specular highlight.
vec3 terrain_phong(vec3 albedo, vec3 N, vec3 L, vec3 V) {
    if (LIGHTING_MODE == 3) {
        vec2 vis = sun_sky_visibility();
        vec3 c = daylight_radiance(srgb_to_linear(albedo), N, vis.x, vis.y);
        if (u_ks > 0.0 && dot(N, L) > 0.0) {
            c += u_ks * 0.05 * vis.x * u_sun_irradiance
               * pow(max(dot(reflect(-L, N), V), 0.0), u_shininess);
        }
        return c;
    }
    return phong_sun(albedo, N, L, V, object_sun_visibility());
}
#define phong terrain_phong

// The unlit colour of techniques that call unlit() themselves (bump, relief), with the
// objects' cascaded shadows.
vec3 terrain_unlit(vec3 albedo) {
    return unlit_sun(albedo, object_sun_visibility());
}
#define unlit terrain_unlit

#if defined TERRAIN_VERTEX_HAZE && !defined DEFERRED
#if TERRAIN_VERTEX_HAZE
#define HAZE_PER_VERTEX
in vec3 v_haze_transmittance;   // common/terrain_vertex.glsl
in vec3 v_haze_inscatter;
#endif
#endif
vec4 finish(vec3 color) {
    if (LIGHTING_MODE == 3) {
#ifdef HAZE_PER_VERTEX
        return vec4(display(color * v_haze_transmittance + v_haze_inscatter), 1.0);
#else
        return vec4(display(aerial_perspective(color, v_world, u_camera_pos)), 1.0);
#endif
    }
    return vec4(apply_fog(color, distance(v_world, u_camera_pos)), 1.0);
}

// Sky: a full-screen triangle behind the terrain (drawn where no terrain is).
// Daylight lighting: the sky (a table of the Preetham day / twilight / moonlit / night sky,
// common/atmosphere.glsl) with the sun's disc, the moon's disc in its phase and the stars
// (terrascape.render.atmosphere), and below the horizon the world
// beyond the terrain (`surround`): the sea, an infinite plane at the terrain's lowest height,
// or haze — each hazed by aerial perspective, so it meets the sky without a band.
// Other lighting modes: the view ray's elevation blends the horizon colour (also the fog
// colour) to the zenith colour, plus a glow around the sun.
#if defined VERTEX_SHADER
uniform mat4 u_inv_view_proj;
out vec3 v_ray;
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    // World points on the near plane and on a plane of constant depth are affine in screen
    // position for a perspective projection, so their difference interpolates exactly per vertex and the
    // fragments skip two matrix products (the sky covers most of the screen).
    vec4 a = u_inv_view_proj * vec4(p, -1.0, 1.0);
    // NDC depth 0, not 1: with an infinite far plane NDC 1 lies beyond infinity
    vec4 b = u_inv_view_proj * vec4(p, 0.0, 1.0);
    v_ray = b.xyz / b.w - a.xyz / a.w;
    gl_Position = vec4(p, 1.0, 1.0);
}
#elif defined FRAGMENT_SHADER
#include "common/lighting.glsl"
#include "common/atmosphere.glsl"
#include "common/water.glsl"
uniform vec3 u_horizon_color;
uniform vec3 u_zenith_color;
uniform vec3 u_sun_color;
uniform vec3 u_camera_pos;
uniform int u_lighting;
uniform int u_surround;          // 0 fade (haze), 1 plane, 2 sea
uniform float u_surround_height; // world height of the plane / sea
uniform vec3 u_true_sun_dir;     // toward the sun (below the horizon at night)
uniform mat3 u_to_celestial;     // world (horizontal) → equatorial directions
uniform vec3 u_moon_dir;
uniform vec3 u_moon_radiance;    // display-limited, 0 when the moon is down
uniform float u_moon_cos_radius;
uniform float u_star_radiance;   // brightest star (display-limited), 0 by day
uniform int u_star_seed;
in vec3 v_ray;
out vec4 f_color;

// SKY_MODE (a #define of the program, one program per mode): 0 = not daylight (gradient),
// 1 = daylight with haze beyond the edge, 2 = daylight + plane, 3 = daylight + sea. On a
// software rasteriser every path of a shader costs every pixel, so each mode compiles only
// its own; the uniforms u_lighting / u_surround still say the same.
#ifndef SKY_MODE
#define SKY_MODE 0
#endif

#if SKY_MODE == 2
#include "common/hextile.glsl"
// The plane's ground: the material of the terrain's lowest ground as a texture
// (terrascape.texture.lowest_ground_texture: sRGB colour, detail height in A), hex-tiled on
// the same grid, scale and seed as the material technique, so the land continues past the
// edge without a visible period; u_ground_gain scales its mean to u_surround_albedo.
uniform sampler2D u_ground_tex;
uniform vec3 u_ground_gain;
uniform vec3 u_ground_hex;       // hex-tiling rotation, contrast, sharpness
uniform float u_tile_size;       // world units per material repeat
#endif

vec3 surround_radiance(vec3 p) {
    // u_surround_albedo (common/water.glsl): the terrain's edge colour
#if SKY_MODE == 2
    HexTile t = hex_tile(p.xz / u_tile_size, u_ground_hex.x, 0u);
    vec4 a[3];
    hex_fetch(u_ground_tex, t, a);
    vec3 w = hex_blend_weights(t, vec3(a[0].a, a[1].a, a[2].a), u_ground_hex.y,
                               u_ground_hex.z);
    vec3 albedo = srgb_to_linear(w.x * a[0].rgb + w.y * a[1].rgb + w.z * a[2].rgb)
                * u_ground_gain;
    vec3 ground = daylight_radiance(albedo, vec3(0.0, 1.0, 0.0), 1.0, 1.0);
#else
    vec3 ground = daylight_radiance(u_surround_albedo, vec3(0.0, 1.0, 0.0), 1.0, 1.0);
#endif
#if SKY_MODE == 3
    float depth = u_sea_level - water_floor(p.xz);
    return water_shade(p, u_camera_pos, depth, ground, true).rgb;
#else
    return ground;
#endif
}

#if SKY_MODE > 0
// The moon's disc along d: a sphere lit from the sun's direction (its phase), with a faint
// earthshine on the dark side.
vec3 moon_disc(vec3 d) {
    float c = dot(d, u_moon_dir);
    if (c < u_moon_cos_radius - 1e-4) return vec3(0.0);
    float sin_r = sqrt(max(1.0 - u_moon_cos_radius * u_moon_cos_radius, 1e-12));
    vec3 o = (d - u_moon_dir * c) / sin_r;            // disc offset, |o| <= 1
    float r2 = dot(o, o);
    vec3 n = o - u_moon_dir * sqrt(max(1.0 - r2, 0.0)); // the moon's surface normal
    float lit = smoothstep(-0.08, 0.08, dot(n, u_true_sun_dir));
    float edge = 1.0 - smoothstep(0.85, 1.0, r2);
    return u_moon_radiance * (lit + 0.015) * edge;
}

// Integer hash (Jarzynski & Olano 2020, pcg3d): the same stars on every GPU and run.
uvec3 pcg3d(uvec3 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    v ^= v >> 16u;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    return v;
}

// Stars fixed on the celestial sphere: one candidate per cell of a 3-D grid around the
// unit sphere (in equatorial coordinates, so the sky turns with the sidereal time), a
// star in about one cell in 60, its brightness from a power law (few bright, many faint),
// drawn as a Gaussian one pixel wide. No time input: still renders do not twinkle.
const float STAR_GRID = 160.0;
vec3 stars(vec3 d) {
    vec3 e = u_to_celestial * d;
    vec3 p = e * STAR_GRID;
    vec3 cell = floor(p);
    uvec3 h = pcg3d(uvec3(ivec3(cell) + 4096) ^ uvec3(uint(u_star_seed) * 747796405u));
    vec3 r = vec3(h) * (1.0 / 4294967296.0);
    if (r.x > 1.0 / 60.0) return vec3(0.0);
    vec3 star = cell + 0.3 + 0.4 * fract(r * 61.0 + r.yzx * 17.0);
    // angular distance (in cell units at the sphere) from the view ray to the star
    vec3 off = star - e * dot(star, e);
    float pixel = max(length(fwidth(p)), 1e-4);
    float sigma = 0.7 * pixel;
    float g = exp(-0.5 * dot(off, off) / (sigma * sigma));
    float mag = pow(r.y, 6.0);                          // brightness: many faint stars
    float t = r.z;                                       // colour: blue-white … orange
    vec3 tint = mix(vec3(0.75, 0.85, 1.0), vec3(1.0, 0.8, 0.6), t * t);
    // extinction toward the horizon
    float air = smoothstep(0.0, 0.12, d.y);
    return tint * (u_star_radiance * (0.04 + mag) * g * air);
}

// SKY_MOON / SKY_STARS (defines of the program, like SKY_MODE): the moon's disc and the
// stars are compiled in only when the frame has them — a software rasteriser runs every
// branch for every pixel, and they would cost the whole sky by day.
#ifndef SKY_MOON
#define SKY_MOON 0
#endif
#ifndef SKY_STARS
#define SKY_STARS 0
#endif
vec3 night_sky(vec3 d) {
    vec3 c = vec3(0.0);
#if SKY_MOON
    c += moon_disc(d);
#endif
#if SKY_STARS
    c += stars(d);
#endif
    return c;
}
#endif

void main() {
    vec3 d = normalize(v_ray);
#if SKY_MODE > 0
    vec3 color;
#if SKY_MODE > 1
    float t = (u_surround_height - u_camera_pos.y) / min(d.y, -1e-6);
    // outside the branch: the plane's texture lookups take screen derivatives of p
    vec3 p = u_camera_pos + t * d;
    vec3 ground = surround_radiance(p);
    if (d.y < 0.0 && t > 0.0) {
        color = aerial_perspective(ground, p, u_camera_pos);
    } else {
        color = sky_radiance(d) + sun_disc(d, u_true_sun_dir) + night_sky(d);
    }
#else
    color = sky_radiance(d) + sun_disc(d, u_true_sun_dir) + night_sky(d);
#endif
    f_color = vec4(display(color), 1.0);
#else
    float up = clamp(d.y, 0.0, 1.0);
    vec3 color = mix(u_horizon_color, u_zenith_color, sqrt(up));
    if (d.y < 0.0) color = u_horizon_color * (1.0 - 0.25 * clamp(-d.y * 3.0, 0.0, 1.0));
    float s = max(dot(d, normalize(u_sun_dir)), 0.0);
    color += u_sun_color * (pow(s, 512.0) * 2.0 + pow(s, 16.0) * 0.25);
    f_color = vec4(color, 1.0);
#endif
}
#endif

// Sun visibility from the cascaded shadow maps of objects and terrain
// (terrascape.render.cascades: practical splits, texel-snapped orthographic sun boxes).
// The cascades sit side by side in one depth texture; cascade k covers the view distances
// up to u_cascade_far[k]. Four taps of the hardware's bilinear 2×2 depth comparison (PCF)
// soften the edge over about two texels. u_cascade_count 0 switches the lookup off
// (visibility 1).
#include "common/lighting.glsl"

uniform int u_cascade_count;
uniform sampler2DShadow u_cascade_depth;
uniform mat4 u_cascade_matrix[4];  // world → light clip space of each cascade
uniform vec4 u_cascade_far;        // far view distance of each cascade
uniform vec4 u_cascade_texel;      // world size of one texel of each cascade
uniform vec4 u_cascade_bias;       // depth bias of each cascade (depth units)
uniform vec3 u_cascade_eye;        // view camera position and forward axis (the split
uniform vec3 u_cascade_forward;    // distances are measured along it)

// Normal offset of an object's own surfaces (texels at grazing light ×3): objects are drawn
// into the maps, so their lit faces must clear their own texels ("acne"); the casters'
// slope-scaled polygon offset does most of that already, and a larger offset moves every
// lookup sideways in the map — shadows slide off their casters by that much.
const float CASCADE_OBJECT_OFFSET = 0.25;

// Visible share of the sun at world point p with unit normal n. The point is moved along
// its normal by offset · (1 + 2 sin θ) texels (θ between the normal and the sun: more where
// the surface is steep to the light) before the lookup, so a surface that is drawn into the
// maps does not shadow itself from its own texels. The terrain takes none: it is not in the
// maps (unless cascade_terrain), and moving it would only shift the shadows it receives —
// at 512² cascades over a few hundred metres by a metre or more, the width of a trunk's
// shadow. Drawn into the maps (cascade_terrain) it still does better without: the casters'
// slope-scaled polygon offset keeps it off its own texels, and 0.75 texels × (1 + 2 sin θ)
// made the terrain's shadow on itself agree with the ray cast on 93 % of the samples
// instead of 99 % (terrascape bench objects --quick, 2026-12-02).
float cascade_sun_visibility(vec3 p, vec3 n, float offset) {
    if (u_cascade_count == 0) {
        return 1.0;
    }
    float d = dot(p - u_cascade_eye, u_cascade_forward);
    int k = 0;
    while (k < u_cascade_count - 1 && d > u_cascade_far[k]) {
        ++k;
    }
    float texel = u_cascade_texel[k];
    float ndl = clamp(dot(n, u_sun_dir), 0.0, 1.0);
    vec3 q = p + n * (texel * offset * (1.0 + 2.0 * sqrt(1.0 - ndl * ndl)));
    vec3 c = (u_cascade_matrix[k] * vec4(q, 1.0)).xyz * 0.5 + 0.5;
    if (any(lessThan(c, vec3(0.0))) || any(greaterThan(c, vec3(1.0)))) {
        return 1.0;
    }
    vec2 size = vec2(textureSize(u_cascade_depth, 0));
    float res = size.y;
    // this cascade's tile: x in [k·res, (k+1)·res) texels; taps stay inside it
    vec2 texel_uv = 1.0 / size;
    float x0 = (float(k) * res + 1.0) / size.x;
    float x1 = (float(k + 1) * res - 1.0) / size.x;
    vec2 uv = vec2((float(k) + c.x) * res / size.x, c.y);
    float z = c.z - u_cascade_bias[k];
    // 4 taps half a texel apart, each a bilinear 2×2 comparison: a tent filter over 3×3
    // texels for the price of 4 lookups
    float lit = 0.0;
    for (int i = 0; i < 4; ++i) {
        vec2 t = uv + (vec2(float(i & 1), float(i >> 1)) - 0.5) * texel_uv;
        t.x = clamp(t.x, x0, x1);
        lit += texture(u_cascade_depth, vec3(t, z));
    }
    return 0.25 * lit;
}

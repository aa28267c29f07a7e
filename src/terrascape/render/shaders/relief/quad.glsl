// One relief-textured quad (Janković 2010 §2.3–2.4): the measurement program.
// Compile with `#define TECHNIQUE n` (see relief/common/heightfield.glsl).
//
// u_output: 0 = shaded colour (Phong, Janković 2010 §2.2, with optional self-shadowing);
//           1 = (hit u, hit v, hit depth, texture fetches)  — written to an RGBA32F target;
//           2 = (shadow 0/1, hit depth, texture fetches, 1).

#if defined VERTEX_SHADER

uniform mat4 u_mvp;
in vec3 in_position;
in vec2 in_uv;
out vec3 v_world;
out vec2 v_uv;

void main() {
    v_world = in_position;
    v_uv = in_uv;
    gl_Position = u_mvp * vec4(in_position, 1.0);
}

#elif defined FRAGMENT_SHADER

#include "relief/common/heightfield.glsl"

uniform vec3 u_eye;
uniform mat3 u_world_to_uvd;   // world direction -> (du, dv, d depth); see ReliefQuad
uniform mat3 u_world_to_ts;    // world direction -> orthonormal tangent frame (T, B, N)
uniform vec3 u_light_dir;      // world, toward the light
uniform int u_output;
uniform int u_shadows;         // self-shadowing on/off
uniform int u_has_colour;
uniform sampler2D u_colour;
uniform vec3 u_ambient;        // ka * ia
uniform vec3 u_diffuse;        // kd * id
uniform vec3 u_specular;       // ks * is
uniform float u_shininess;     // alpha

in vec3 v_world;
in vec2 v_uv;
out vec4 frag;

void main() {
    relief_begin(v_uv);
    vec3 dir = u_world_to_uvd * (v_world - u_eye);
    vec2 ds = dir.xy / max(dir.z, 1e-9);
#if TECHNIQUE == TECH_BY_DISTANCE
    vec3 hit = relief_trace_by_distance(v_uv, ds, distance(v_world, u_eye));
#else
    vec3 hit = relief_trace(v_uv, ds);
#endif
    float shadow = 0.0;
    if (u_shadows != 0) {
        vec3 l = u_world_to_uvd * u_light_dir;
        shadow = l.z < 0.0 ? relief_shadow(hit, l.xy / -l.z) : 1.0;
    }
    if (u_output == 1) {
        frag = vec4(hit.xy, hit.z, float(g_fetches));
        return;
    }
    if (u_output == 2) {
        frag = vec4(shadow, hit.z, float(g_fetches), 1.0);
        return;
    }
    // Phong: I = ka ia + kd (L.N) id + ks (R.V)^alpha is  (Janković 2010 §2.2)
    vec4 t = textureGrad(u_relief, hit.xy, g_uv_dx, g_uv_dy);
    vec3 n = normalize(t.rgb * 2.0 - 1.0);
    vec3 L = normalize(u_world_to_ts * u_light_dir);
    vec3 V = normalize(u_world_to_ts * (u_eye - v_world));
    vec3 R = reflect(-L, n);
    float lit = 1.0 - shadow;
    vec3 albedo = u_has_colour != 0 ? textureGrad(u_colour, hit.xy, g_uv_dx, g_uv_dy).rgb
                                    : vec3(t.a * 0.6 + 0.3);
    vec3 colour = albedo * (u_ambient + lit * max(dot(L, n), 0.0) * u_diffuse)
                + lit * pow(max(dot(R, V), 0.0), u_shininess) * u_specular;
    frag = vec4(colour, 1.0);
}

#endif

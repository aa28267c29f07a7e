// Phong illumination (seed 000 §2.5, R2):
//   I = ka*ia + kd*(L.N)*id + ks*(R.V)^alpha*is
// L points toward the sun, V toward the eye, R = reflect(-L, N). The albedo modulates the
// ambient and diffuse terms; the specular highlight keeps the light's colour.
uniform vec3 u_sun_dir;         // unit vector toward the sun (terrascape.lighting.sun)
uniform vec3 u_ambient_color;   // ia
uniform vec3 u_diffuse_color;   // id
uniform vec3 u_specular_color;  // is
uniform float u_ka;
uniform float u_kd;
uniform float u_ks;
uniform float u_shininess;      // alpha

vec3 phong(vec3 albedo, vec3 N, vec3 L, vec3 V) {
    float ndotl = dot(N, L);
    vec3 color = albedo * (u_ka * u_ambient_color + u_kd * max(ndotl, 0.0) * u_diffuse_color);
    if (ndotl > 0.0 && u_ks > 0.0) {
        vec3 R = reflect(-L, N);
        color += u_ks * pow(max(dot(R, V), 0.0), u_shininess) * u_specular_color;
    }
    return color;
}

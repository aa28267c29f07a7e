// Lighting models of the terrain techniques.
//
// Phong illumination (Janković 2010 §2.5):
//   I = ka*ia + kd*(L.N)*id + ks*(R.V)^alpha*is
// L points toward the sun, V toward the eye, R = reflect(-L, N). The albedo modulates the
// ambient and diffuse terms; the specular highlight keeps the light's colour.
//
// Daylight (terrascape.lighting.daylight, the same formula as the CPU lightmap): irradiance
//   E = E_sun·max(N·L, 0)·v_sun + E_sky·(1 + N_y)/2·v_sky + E_ground·((1 - N_y)/2
//       + (1 - v_sky)·(1 + N_y)/2)
// with v_sun the visible share of the sun's disc (soft shadow) and v_sky the sky-view
// factor; a Lambertian surface of linear albedo a has radiance a·E/π.
uniform vec3 u_sun_dir;         // unit vector toward the sun (terrascape.lighting.sun)
uniform vec3 u_ambient_color;   // ia
uniform vec3 u_diffuse_color;   // id
uniform vec3 u_specular_color;  // is
uniform float u_ka;
uniform float u_kd;
uniform float u_ks;
uniform float u_shininess;      // alpha

// 1 in the pass that draws again the surfaces inside the objects' shadow volumes
// (terrascape.render.shadow_volumes): the sun's direct light is off in every lighting model
// (daylight and Phong also get their sun terms set to 0; the lightmap and unlit modes read
// this flag).
uniform int u_sun_blocked;

uniform vec3 u_sun_irradiance;     // klx at normal incidence, white-balanced
uniform vec3 u_sky_irradiance;     // klx on open horizontal ground from the sky
uniform vec3 u_ground_irradiance;  // ground albedo × irradiance of open sunlit ground

// A surface under no lighting model shows its albedo; in an object's shadow, the ambient
// share Phong lighting leaves there (ka·ia), so the shadow shows in unlit frames too.
vec3 unlit(vec3 albedo) {
    return u_sun_blocked != 0 ? albedo * (u_ka * u_ambient_color) : albedo;
}

// The same where a share ``sun`` of the sun is visible (a shadow map's filtered lookup):
// between the shadowed and the unshadowed colour.
vec3 unlit_sun(vec3 albedo, float sun) {
    return mix(albedo * (u_ka * u_ambient_color), unlit(albedo), sun);
}

// Phong with the sun's terms (diffuse and specular) scaled by its visible share ``sun``.
vec3 phong_sun(vec3 albedo, vec3 N, vec3 L, vec3 V, float sun) {
    float ndotl = dot(N, L);
    vec3 color = albedo * (u_ka * u_ambient_color
                           + u_kd * max(ndotl, 0.0) * sun * u_diffuse_color);
    if (ndotl > 0.0 && u_ks > 0.0) {
        vec3 R = reflect(-L, N);
        color += u_ks * sun * pow(max(dot(R, V), 0.0), u_shininess) * u_specular_color;
    }
    return color;
}

vec3 phong(vec3 albedo, vec3 N, vec3 L, vec3 V) {
    return phong_sun(albedo, N, L, V, 1.0);
}

vec3 daylight_irradiance(vec3 N, float sun_visibility, float sky_visibility) {
    float up = 0.5 + 0.5 * N.y;
    return u_sun_irradiance * (max(dot(N, u_sun_dir), 0.0) * sun_visibility)
         + u_sky_irradiance * (up * sky_visibility)
         + u_ground_irradiance * ((1.0 - up) + (1.0 - sky_visibility) * up);
}

// Linear radiance of a Lambertian surface (linear albedo) under the daylight model.
vec3 daylight_radiance(vec3 albedo_linear, vec3 N, float sun_visibility, float sky_visibility) {
    return albedo_linear * daylight_irradiance(N, sun_visibility, sky_visibility)
         * 0.3183098862;
}

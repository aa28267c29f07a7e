// Daylight sky, aerial perspective and display transform (terrascape.lighting.daylight: the
// same formulas and constants, from Daylight.uniforms()).
//  * Preetham, Shirley & Smits 1999 analytic sky: Perez F(θ, γ) = (1 + A e^(B/cos θ))
//    (1 + C e^(Dγ) + E cos²γ) for Y, x, y, times zenith/F(0, θs); Yxy → XYZ → linear sRGB,
//    white-balanced for the overhead sun. e^(B/cos θ) and its derivatives vanish at the
//    horizon, so continuing the sky below it with cos θ clamped has no crease.
//  * Aerial perspective: extinction exp(-β·∫ρ) along the view ray through air whose density
//    falls off as exp(-(y - base)/H), and in-scattered light toward the sky colour of the
//    same view direction at the horizon (distant terrain melts into the sky behind it).
//  * Display: exposure, Narkowicz 2015 ACES fit, sRGB encoding.
uniform vec3 u_sky_sun_dir;      // sun direction of the sky model (>= 0.5° elevation)
uniform float u_perez[15];       // A..E for Y, then x, then y
uniform vec3 u_sky_zenith;       // (Y, x, y) zenith / F(0, θs)
uniform vec3 u_white_balance;
uniform vec3 u_sun_radiance;     // sun disc radiance (display-limited, sun colour)
uniform float u_sun_cos_radius;  // cos of the drawn disc radius
uniform float u_exposure;
uniform vec3 u_haze_beta;        // extinction per world unit at the base height (RGB)
uniform float u_haze_base;       // world height of the haze base (terrain minimum)
uniform float u_haze_height;     // density scale height H (world units)

float perez_term(int k, float cos_theta, float gamma) {
    float A = u_perez[5 * k], B = u_perez[5 * k + 1], C = u_perez[5 * k + 2];
    float D = u_perez[5 * k + 3], E = u_perez[5 * k + 4];
    float cg = cos(gamma);
    return (1.0 + A * exp(B / cos_theta)) * (1.0 + C * exp(D * gamma) + E * cg * cg);
}

// Sky radiance (linear, kcd/m², white-balanced) along unit direction d, without the sun disc.
vec3 sky_radiance(vec3 d) {
    float ct = max(d.y, 1e-4);
    float gamma = acos(clamp(dot(d, u_sky_sun_dir), -1.0, 1.0));
    vec3 yxy = u_sky_zenith * vec3(perez_term(0, ct, gamma), perez_term(1, ct, gamma),
                                   perez_term(2, ct, gamma));
    float Y = yxy.x;
    // y >= x + 0.01: Preetham's chromaticity drifts magenta toward the horizon (daylight.py)
    float y = max(max(yxy.z, yxy.y + 0.01), 1e-4);
    vec3 xyz = vec3(yxy.y * Y / y, Y, (1.0 - yxy.y - y) * Y / y);
    mat3 to_rgb = mat3(3.2406, -0.9689, 0.0557,
                       -1.5372, 1.8758, -0.2040,
                       -0.4986, 0.0415, 1.0570);
    return max(to_rgb * xyz, vec3(0.0)) * u_white_balance;
}

// The sun's disc seen along d (soft-edged), added to the sky where no terrain hides it.
vec3 sun_disc(vec3 d, vec3 sun_dir) {
    float c = dot(d, sun_dir);
    float edge = (1.0 - u_sun_cos_radius) * 0.25;
    return u_sun_radiance * smoothstep(u_sun_cos_radius - edge, u_sun_cos_radius + edge, c);
}

// Haze between the camera and a world point: light of the point attenuated, sky light added.
vec3 aerial_perspective(vec3 radiance, vec3 p, vec3 eye) {
    vec3 ray = p - eye;
    float dist = length(ray);
    float ha = (eye.y - u_haze_base) / u_haze_height;
    float hb = (p.y - u_haze_base) / u_haze_height;
    float dh = hb - ha;
    // ∫ exp(-h) along the segment / its length (the mean density)
    float mean_density = abs(dh) < 1e-3 ? exp(-0.5 * (ha + hb))
                                        : (exp(-ha) - exp(-hb)) / dh;
    vec3 transmittance = exp(-u_haze_beta * dist * mean_density);
    vec3 d = ray / max(dist, 1e-6);
    vec3 horizon = sky_radiance(normalize(vec3(d.x, max(d.y, 0.0), d.z)));
    return radiance * transmittance + horizon * (1.0 - transmittance);
}

vec3 aces_filmic(vec3 x) {
    x = max(x, vec3(0.0));
    return clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 linear_to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}

vec3 srgb_to_linear(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(0.04045, c));
}

// Linear radiance → display value (exposure, filmic tone map, sRGB).
vec3 display(vec3 radiance) {
    return linear_to_srgb(aces_filmic(radiance * u_exposure));
}

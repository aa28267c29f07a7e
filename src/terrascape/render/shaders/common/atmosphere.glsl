// Sky, aerial perspective and display transform (terrascape.lighting.daylight and
// terrascape.lighting.night_sky: the same formulas, evaluated on the CPU).
//  * The sky: Preetham, Shirley & Smits 1999 (the day sky, and the moonlit sky of a "sun"
//    where the moon is), dimmed and blued through twilight, plus the night's airglow —
//    tabulated per frame into u_sky_lut (azimuth × elevation, float radiance), so a sky
//    pixel costs one texture fetch instead of three Perez functions. The table's rows are
//    elevations 90°·(i/(H-1))² (dense near the horizon, where the sky changes fastest);
//    below the horizon the horizon row continues (the Perez model's own continuation).
//  * Aerial perspective: extinction exp(-β·∫ρ) along the view ray through air whose density
//    falls off as exp(-(y - base)/H), and in-scattered light toward the sky colour of the
//    same view direction at the horizon (distant terrain melts into the sky behind it).
//  * Display: exposure, Narkowicz 2015 ACES fit, sRGB encoding.
uniform sampler2D u_sky_lut;     // sky radiance (linear, kcd/m², white-balanced)
uniform vec3 u_sun_radiance;     // sun disc radiance (display-limited, sun colour)
uniform float u_sun_cos_radius;  // cos of the drawn disc radius
uniform float u_exposure;
uniform float u_night_desaturation; // 0 by day; at night colours fade toward blue-grey
uniform vec3 u_haze_beta;        // extinction per world unit at the base height (RGB)
uniform float u_haze_base;       // world height of the haze base (terrain minimum)
uniform float u_haze_height;     // density scale height H (world units)

// Sky radiance (linear, kcd/m², white-balanced) along unit direction d, without the discs.
vec3 sky_radiance(vec3 d) {
    vec2 size = vec2(textureSize(u_sky_lut, 0));
    // turns clockwise from north (straight up, any azimuth: atan(0, 0) is undefined)
    float az = atan(d.x, abs(d.x) + abs(d.z) > 1e-7 ? -d.z : 1.0) * 0.15915494;
    float el = asin(clamp(d.y, 0.0, 1.0)) * 0.63661977; // 0 horizon … 1 zenith
    // texel centres: column j at j/W turns, row i at elevation ((i/(H-1))²
    vec2 uv = vec2(az + 0.5 / size.x, (sqrt(el) * (size.y - 1.0) + 0.5) / size.y);
    return texture(u_sky_lut, uv).rgb;
}

// The sun's disc seen along d (soft-edged), added to the sky where no terrain hides it.
vec3 sun_disc(vec3 d, vec3 sun_dir) {
    float c = dot(d, sun_dir);
    float edge = (1.0 - u_sun_cos_radius) * 0.25;
    return u_sun_radiance * smoothstep(u_sun_cos_radius - edge, u_sun_cos_radius + edge, c);
}

// Haze between the camera and a world point: its transmittance and the sky light scattered
// in along the way.
void haze(vec3 p, vec3 eye, out vec3 transmittance, out vec3 inscatter) {
    vec3 ray = p - eye;
    float dist = length(ray);
    float ha = (eye.y - u_haze_base) / u_haze_height;
    float hb = (p.y - u_haze_base) / u_haze_height;
    float dh = hb - ha;
    // ∫ exp(-h) along the segment / its length (the mean density)
    float mean_density = abs(dh) < 1e-3 ? exp(-0.5 * (ha + hb))
                                        : (exp(-ha) - exp(-hb)) / dh;
    transmittance = exp(-u_haze_beta * dist * mean_density);
    vec3 d = ray / max(dist, 1e-6);
    vec3 horizon = sky_radiance(normalize(vec3(d.x, max(d.y, 0.0), d.z)));
    inscatter = horizon * (1.0 - transmittance);
}

// Haze between the camera and a world point: light of the point attenuated, sky light added.
vec3 aerial_perspective(vec3 radiance, vec3 p, vec3 eye) {
    vec3 transmittance, inscatter;
    haze(p, eye, transmittance, inscatter);
    return radiance * transmittance + inscatter;
}

vec3 aces_filmic(vec3 x) {
    x = max(x, vec3(0.0));
    return clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

// The sRGB transfer curves as polynomials: a software rasteriser evaluates pow() as a log2
// and an exp2 series per channel, a tenth of a plain terrain frame on llvmpipe for the two
// curves; these take a few multiply-adds (and two square roots). Minimax fits to the
// standard's curves (IEC 61966-2-1), refit with scripts/fit_srgb_curves.py:
// 1.055·c^(1/2.4) − 0.055 on [0.0031308, 1] as a quartic in c^(1/4), within 0.017/255;
// ((c + 0.055)/1.055)^2.4 on [0.04045, 1] as a quintic in c, within 0.027/255 once encoded
// back — below the 8-bit step, so frames are the same to one level.
vec3 linear_to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 t = sqrt(sqrt(c));
    vec3 curve = -0.0661686867 + t * (0.2095252061 + t * (1.0831764558
                 + t * (-0.2877598526 + t * 0.0611607983)));
    return mix(12.92 * c, curve, step(0.0031308, c));
}

vec3 srgb_to_linear(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 curve = 0.0009679013 + c * (0.0309949028 + c * (0.5365178597 + c * (0.6060151960
                 + c * (-0.2216193675 + c * 0.0468864463))));
    return mix(c / 12.92, curve, step(0.04045, c));
}

// Linear radiance → display value (exposure, filmic tone map, sRGB).
vec3 display(vec3 radiance) {
    // scotopic vision: at night the colours fade to a blue-grey of the same luminance
    float lum = dot(radiance, vec3(0.2126, 0.7152, 0.0722));
    radiance = mix(radiance, lum * vec3(0.78, 0.95, 1.45), u_night_desaturation);
    return linear_to_srgb(aces_filmic(radiance * u_exposure));
}

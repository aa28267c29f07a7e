// Water surface at sea level (terrascape.render.water): Fresnel (Schlick) reflection of the
// sky and the sun, light scattered in the water body, depth-tinted transparency over the
// terrain below it and foam along the shore, from the terrain height under the point.
// Needs common/atmosphere.glsl and common/lighting.glsl.
uniform sampler2D u_height;       // world heights (exaggerated), one texel per vertex
uniform vec2 u_height_extent;     // world size (x, z) of the height texture
uniform float u_sea_level;        // world height of the water surface
uniform float u_time;             // seconds (ripples move)
uniform float u_wave_length;      // world units of the longest ripple
uniform vec3 u_water_extinction;  // per world unit of depth (RGB)
uniform float u_foam_depth;       // depth below which the shore foams
uniform float u_shelf_slope;      // sea floor drop per world unit beyond the terrain's edge
uniform vec3 u_surround_albedo;   // linear albedo of the ground beyond the terrain

float terrain_height_at(vec2 xz) {
    vec2 size = vec2(textureSize(u_height, 0));
    vec2 uv = (clamp(xz / u_height_extent, 0.0, 1.0) * (size - 1.0) + 0.5) / size;
    return texture(u_height, uv).r;
}

// Height of the ground under the water at xz: the terrain, and beyond its edge a sea floor
// that falls away from the edge's height (a shelf), so the coast continues as a shore and
// the open sea is deep.
float water_floor(vec2 xz) {
    vec2 q = clamp(xz, vec2(0.0), u_height_extent);
    return terrain_height_at(q) - distance(xz, q) * u_shelf_slope;
}

bool inside_terrain(vec2 xz) {
    return all(greaterThanEqual(xz, vec2(0.0))) && all(lessThanEqual(xz, u_height_extent));
}

// Sum of directional sine ripples: slope (dh/dx, dh/dz) at xz.
vec2 ripple_slope(vec2 xz, float fade) {
    vec2 slope = vec2(0.0);
    float lambda = u_wave_length;
    float amp = 0.035;
    for (int k = 0; k < 4; ++k) {
        float a = 1.3 + 2.1 * float(k);
        vec2 dir = vec2(cos(a), sin(a));
        float w = 6.2831853 / lambda;
        float speed = sqrt(9.81 * lambda / 6.2831853) * 0.05 * lambda;
        float phase = w * dot(dir, xz) + u_time * speed * w;
        slope += dir * (amp * cos(phase));
        lambda *= 0.57;
        amp *= 0.8;
    }
    return slope * fade;
}

// Linear radiance and coverage (alpha) of the water at world point p with depth `depth`;
// `bottom` is the radiance of what lies below (used when opaque = true, the sea beyond the
// terrain; otherwise the framebuffer is blended in with alpha).
vec4 water_shade(vec3 p, vec3 eye, float depth, vec3 bottom, bool opaque) {
    vec3 V = normalize(eye - p);
    float dist = distance(eye, p);
    // Ripples fade out with distance (their pixels would alias) toward a flat mirror.
    float fade = clamp(8.0 * u_wave_length / max(dist, 1e-3), 0.0, 1.0);
    vec2 s = ripple_slope(p.xz, fade);
    vec3 N = normalize(vec3(-s.x, 1.0, -s.y));
    float cos_v = clamp(dot(N, V), 0.0, 1.0);
    float F = 0.02 + 0.98 * pow(1.0 - cos_v, 5.0);
    vec3 R = reflect(-V, N);
    R.y = abs(R.y);
    vec3 reflected = sky_radiance(normalize(R));
    // Sun glint: a normalised Phong lobe around the mirror direction.
    float glint = pow(max(dot(R, u_sun_dir), 0.0), 600.0) * 96.0;
    reflected += u_sun_irradiance * glint * step(0.0, u_sun_dir.y);
    vec3 light = u_sun_irradiance * max(u_sun_dir.y, 0.0) + u_sky_irradiance;
    vec3 body = light * vec3(0.010, 0.030, 0.036);  // light scattered back by the water
    vec3 T = exp(-u_water_extinction * max(depth, 0.0) * (1.0 + 1.0 / max(cos_v, 0.2)));
    float t = dot(T, vec3(0.2126, 0.7152, 0.0722));
    vec3 color;
    float alpha;
    if (opaque) {
        color = F * reflected + (1.0 - F) * (body * (1.0 - T) + bottom * T);
        alpha = 1.0;
    } else {
        alpha = 1.0 - (1.0 - F) * t;
        color = (F * reflected + (1.0 - F) * body * (1.0 - T)) / max(alpha, 1e-3);
    }
    // Foam where the water is shallow, broken up by the ripples.
    float foam = 1.0 - smoothstep(0.0, u_foam_depth, depth);
    foam *= 0.55 + 0.45 * sin(p.x / u_wave_length * 17.0 + u_time)
                       * sin(p.z / u_wave_length * 13.0 - 0.7 * u_time);
    foam = clamp(foam * fade, 0.0, 1.0);  // far away the foam pattern would alias
    color = mix(color, light * 0.75 * 0.3183098862, foam);
    alpha = mix(alpha, 1.0, foam);
    return vec4(color, alpha);
}

// Distance fog shared by every technique (and matched by the sky's horizon colour).
// Exponential-squared fog: f = exp(-(density * d)^2); density 0 switches it off.
uniform vec3 u_fog_color;
uniform float u_fog_density;

vec3 apply_fog(vec3 color, float dist) {
    float k = u_fog_density * dist;
    float visibility = exp(-k * k);
    return mix(u_fog_color, color, visibility);
}

// Sky: a full-screen triangle behind the terrain; the view ray's elevation blends the
// horizon colour (also the fog colour, so distant terrain melts into it) to the zenith
// colour, plus a glow around the sun.
#if defined VERTEX_SHADER
uniform mat4 u_inv_view_proj;
out vec3 v_ray;
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    // World points on the near and far planes are affine in screen position for a
    // perspective projection, so their difference interpolates exactly per vertex and the
    // fragments skip two matrix products (the sky covers most of the screen).
    vec4 a = u_inv_view_proj * vec4(p, -1.0, 1.0);
    vec4 b = u_inv_view_proj * vec4(p, 1.0, 1.0);
    v_ray = b.xyz / b.w - a.xyz / a.w;
    gl_Position = vec4(p, 1.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform vec3 u_horizon_color;
uniform vec3 u_zenith_color;
uniform vec3 u_sun_color;
uniform vec3 u_sun_dir;
in vec3 v_ray;
out vec4 f_color;
void main() {
    vec3 d = normalize(v_ray);
    float up = clamp(d.y, 0.0, 1.0);
    vec3 color = mix(u_horizon_color, u_zenith_color, sqrt(up));
    if (d.y < 0.0) color = u_horizon_color * (1.0 - 0.25 * clamp(-d.y * 3.0, 0.0, 1.0));
    float s = max(dot(d, normalize(u_sun_dir)), 0.0);
    color += u_sun_color * (pow(s, 512.0) * 2.0 + pow(s, 16.0) * 0.25);
    f_color = vec4(color, 1.0);
}
#endif

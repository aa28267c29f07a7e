// Flat-coloured geometry: wireframe overlay and tests of the program loader.
#if defined VERTEX_SHADER
in vec3 in_position;
uniform mat4 u_view_proj;
void main() {
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform vec4 u_color;
out vec4 f_color;
void main() {
    f_color = u_color;
}
#endif

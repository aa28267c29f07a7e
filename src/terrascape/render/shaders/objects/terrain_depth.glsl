// The terrain as a shadow caster in the sun's cascades (terrascape.render.objects): depth
// only, from a grid thinned to about the cascade's texel size.
#if defined VERTEX_SHADER
in vec3 in_position;
uniform mat4 u_view_proj;

void main() {
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
#elif defined FRAGMENT_SHADER
void main() {
}
#endif

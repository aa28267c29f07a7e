// Shadow volume faces for the stencil count (terrascape.render.shadow_volumes): homogeneous
// world vertices, w = 0 for the points at infinity the silhouette is extruded to. Colour
// writes are off; the fragment stage only exists because a program needs one.
#if defined VERTEX_SHADER
in vec4 in_position;
uniform mat4 u_view_proj;
void main() {
    gl_Position = u_view_proj * in_position;
}
#elif defined FRAGMENT_SHADER
out vec4 f_color;
void main() {
    f_color = vec4(0.0);
}
#endif

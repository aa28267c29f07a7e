// The impostor atlas (terrascape.render.objects): one mesh seen from one direction around
// it, orthographic; albedo and normal (in the mesh's frame) premultiplied by coverage, so
// mip levels and the cross-fade of two views average them over the covered texels only.
#if defined VERTEX_SHADER
in vec3 in_position;
in vec3 in_normal;
in vec3 in_color;
uniform mat4 u_bake;
out vec3 v_normal;
out vec3 v_color;

void main() {
    v_normal = in_normal;
    v_color = in_color;
    gl_Position = u_bake * vec4(in_position, 1.0);
}
#elif defined FRAGMENT_SHADER
in vec3 v_normal;
in vec3 v_color;
layout(location = 0) out vec4 f_albedo;
layout(location = 1) out vec4 f_normal;

void main() {
    f_albedo = vec4(v_color, 1.0);
    f_normal = vec4(normalize(v_normal), 1.0);
}
#endif

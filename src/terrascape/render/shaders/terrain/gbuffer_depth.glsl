// Deferred shading, between the geometry and shading passes: copies the geometry pass's
// depth into the target framebuffer (colour writes masked off), so the shading pass can be
// depth-tested against it and the sky drawn after it keeps to the pixels without terrain.
#if defined VERTEX_SHADER
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)) * 2.0 - 1.0;
    gl_Position = vec4(p, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_gbuffer_depth;
out vec4 f_color;  // masked off
void main() {
    gl_FragDepth = texelFetch(u_gbuffer_depth, ivec2(gl_FragCoord.xy), 0).r;
    f_color = vec4(0.0);
}
#endif

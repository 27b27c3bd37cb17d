#version 430 core
// Full-screen triangle (3 vertices, no buffers): premultiplied RGBA to straight alpha,
// texel for texel (used for a read-back when the background is not opaque).
#if defined VERTEX_SHADER
void main() {
    vec2 corner = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1));
    gl_Position = vec4(corner - 1.0, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_color;
out vec4 f_color;
void main() {
    vec4 c = texelFetch(u_color, ivec2(gl_FragCoord.xy), 0);
    f_color = c.a > 0.0 ? vec4(min(c.rgb / c.a, 1.0), c.a) : vec4(0.0);
}
#endif

#version 330 core
// Full-screen triangle (3 vertices, no buffers): puts the background (premultiplied,
// stretched over the canvas with linear filtering; a 1x1 texture for a plain colour)
// under the premultiplied accumulation and writes straight alpha.
#if defined VERTEX_SHADER
out vec2 v_uv;
void main() {
    vec2 corner = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1));
    v_uv = corner * 0.5;
    gl_Position = vec4(corner - 1.0, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_accum;
uniform sampler2D u_background;
in vec2 v_uv;
out vec4 f_color;
void main() {
    vec4 a = texelFetch(u_accum, ivec2(gl_FragCoord.xy), 0);
    vec4 c = clamp(a + (1.0 - a.a) * texture(u_background, v_uv), 0.0, 1.0);
    f_color = c.a > 0.0 ? vec4(min(c.rgb / c.a, 1.0), c.a) : vec4(0.0);
}
#endif

#version 330 core
// Full-screen triangle (3 vertices, no buffers): puts a peel under the premultiplied
// front-to-back accumulation, A' = A + (1 - A.a) * peel, reading A from one texture
// and writing A' to another (ping-pong). It also writes the depth buffer of the next
// peel: 0 where A' is (nearly) opaque, so that nothing behind is drawn again there,
// 1 elsewhere (which doubles as that buffer's clear).
#if defined VERTEX_SHADER
void main() {
    vec2 corner = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1));
    gl_Position = vec4(corner - 1.0, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_accum;  // accumulation so far (premultiplied)
uniform sampler2D u_peel;   // this peel (premultiplied)
uniform float u_opaque;     // alpha from which a pixel is final
out vec4 f_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 a = texelFetch(u_accum, p, 0);
    vec4 c = a + (1.0 - a.a) * texelFetch(u_peel, p, 0);
    f_color = c;
    gl_FragDepth = c.a >= u_opaque ? 0.0 : 1.0;
}
#endif

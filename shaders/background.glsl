#version 430 core
// Full-screen triangle (3 vertices, no buffers): the background image (premultiplied,
// bilinear) stretched over the whole canvas, written as the frame's first colour.
// u_flip = 1 puts the canvas top at the framebuffer's last row (for a window).
#if defined VERTEX_SHADER
uniform float u_flip;
out vec2 v_uv;
void main() {
    vec2 corner = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1));
    v_uv = vec2(corner.x * 0.5, mix(corner.y * 0.5, 1.0 - corner.y * 0.5, u_flip));
    gl_Position = vec4(corner - 1.0, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_background;
in vec2 v_uv;
out vec4 f_color;
vec4 texel(ivec2 p, ivec2 size) {
    return texelFetch(u_background, clamp(p, ivec2(0), size - 1), 0);
}
void main() {
    // bilinear in float (the texture unit's 8-bit weights are off by ~1 grey level on
    // a magnified image), clamp to edge, texel centres at (i + 0.5) / size
    ivec2 size = textureSize(u_background, 0);
    vec2 s = v_uv * vec2(size) - 0.5;
    ivec2 i = ivec2(floor(s));
    vec2 f = s - vec2(i);
    vec4 top = mix(texel(i, size), texel(i + ivec2(1, 0), size), f.x);
    vec4 bottom = mix(texel(i + ivec2(0, 1), size), texel(i + ivec2(1, 1), size), f.x);
    f_color = mix(top, bottom, f.y);
}
#endif

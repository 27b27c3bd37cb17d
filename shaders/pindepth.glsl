#version 430 core
// Per-pixel pin depth (puppet/render/compositor.py, Compositor.pin_depth): every
// non-empty triangle of every layer, a fragment kept where the texel under it (nearest,
// texelFetch) has alpha > 0; the depth test keeps the front-most one (window depth
// (hi - d) / (hi - lo) with u_depth = (hi, 1 / (hi - lo)), LEQUAL, so at a tie the later
// triangle and the later layer win, as in the compositor); it writes (d - u_rank, 1):
// its depth less the layer's stacking rank, and a coverage flag. u_ndc maps canvas
// pixels to NDC with canvas row 0 at framebuffer row 0 (read back without a flip).
#if defined VERTEX_SHADER
uniform vec4 u_ndc;
uniform vec2 u_depth;
uniform float u_rank;
in vec2 in_pos;
in float in_depth;
in vec2 in_uv;
out vec2 v_uv;
out float v_pin;
void main() {
    v_uv = in_uv;
    v_pin = in_depth - u_rank;
    float z = clamp((u_depth.x - in_depth) * u_depth.y, 0.0, 1.0);
    gl_Position = vec4(in_pos * u_ndc.xy + u_ndc.zw, 2.0 * z - 1.0, 1.0);
}

#elif defined FRAGMENT_SHADER
uniform sampler2D u_texture;
in vec2 v_uv;
in float v_pin;
out vec2 f_depth;
void main() {
    ivec2 size = textureSize(u_texture, 0);
    ivec2 texel = clamp(ivec2(floor(v_uv * vec2(size))), ivec2(0), size - 1);
    if (texelFetch(u_texture, texel, 0).a <= 0.0) discard;
    f_depth = vec2(v_pin, 1.0);
}
#endif

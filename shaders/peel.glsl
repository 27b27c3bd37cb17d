#version 330 core
// One depth peel of the textured layer meshes.
// Vertices: canvas pixels (x right, y down), texture coordinates, window depth in
// [0, 1] (0 = nearest). Canvas y is mapped to framebuffer rows top-first, so reading
// the framebuffer gives row 0 = top of the canvas with no flip.
// The fragment shader discards fragments whose premultiplied texture alpha is below
// ALPHA_MIN and (except with FIRST_PEEL defined) fragments at or in front of the
// previous peel's depth + u_epsilon; the depth test (LESS) then keeps, per pixel, the
// nearest fragment not yet peeled.
#if defined VERTEX_SHADER
uniform vec2 u_canvas;
in vec2 in_pos;
in vec2 in_uv;
in float in_z;
out vec2 v_uv;
void main() {
    v_uv = in_uv;
    gl_Position = vec4(in_pos / u_canvas * 2.0 - 1.0, in_z * 2.0 - 1.0, 1.0);
}
#elif defined FRAGMENT_SHADER
const float ALPHA_MIN = 0.5 / 255.0;  // keep in sync with compositor.ALPHA_MIN
uniform sampler2D u_texture;     // premultiplied RGBA, linear, clamp to edge
#if !defined FIRST_PEEL
uniform sampler2D u_prev_depth;  // depth buffer of the previous peel
uniform float u_epsilon;
#endif
in vec2 v_uv;
out vec4 f_color;
void main() {
#if !defined FIRST_PEEL
    float prev = texelFetch(u_prev_depth, ivec2(gl_FragCoord.xy), 0).r;
    if (gl_FragCoord.z <= prev + u_epsilon) discard;
#endif
    vec4 color = texture(u_texture, v_uv);
    if (color.a < ALPHA_MIN) discard;
    f_color = color;
}
#endif

#version 330
// The app's quads given in window pixels (puppet/app/gl/canvas.py, onion.py), one variant each:
//   (none)       a texture at an opacity: the composited canvas, the background picture,
//                the reference underlay, a tint, the depth view (u_alpha)
//   CHECKER      the checkerboard behind transparency (u_cell: cell size in pixels)
//   GHOST        an onion-skin ghost: premultiplied in, tinted towards u_tint by u_mix,
//                times u_opacity, premultiplied out
//   PASTEBOARD   the composited layers (premultiplied), times u_dim outside the canvas
//                rect u_canvas (x0, y0, x1, y1 in framebuffer pixels, y up), over
//                u_inside / u_outside (premultiplied; zero: the output blends over the
//                framebuffer, opaque colours: an opaque output in one pass)
#if defined VERTEX_SHADER
uniform vec2 u_screen;
in vec2 in_pos;
#if !defined CHECKER
in vec2 in_uv;
out vec2 v_uv;
#endif
void main() {
#if !defined CHECKER
    v_uv = in_uv;
#endif
    gl_Position = vec4(in_pos.x / u_screen.x * 2.0 - 1.0, 1.0 - in_pos.y / u_screen.y * 2.0, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
out vec4 f_color;
#if defined CHECKER
uniform float u_cell;
void main() {
    vec2 k = floor(gl_FragCoord.xy / u_cell);
    float g = mod(k.x + k.y, 2.0) < 0.5 ? 1.0 : 0.8;
    f_color = vec4(g, g, g, 1.0);
}
#elif defined GHOST
uniform sampler2D u_texture;
uniform vec3 u_tint;
uniform float u_mix;
uniform float u_opacity;
in vec2 v_uv;
void main() {
    vec4 c = texture(u_texture, v_uv);
    f_color = vec4(mix(c.rgb, u_tint * c.a, u_mix), c.a) * u_opacity;
}
#elif defined PASTEBOARD
uniform sampler2D u_texture;
uniform vec4 u_canvas;
uniform float u_dim;
uniform vec4 u_inside;
uniform vec4 u_outside;
in vec2 v_uv;
void main() {
    vec4 c = texture(u_texture, v_uv);
    bool inside = all(greaterThanEqual(gl_FragCoord.xy, u_canvas.xy)) && all(lessThan(gl_FragCoord.xy, u_canvas.zw));
    f_color = inside ? c + u_inside * (1.0 - c.a) : c * u_dim + u_outside * (1.0 - c.a * u_dim);
}
#else
uniform sampler2D u_texture;
uniform float u_alpha;
in vec2 v_uv;
void main() {
    vec4 c = texture(u_texture, v_uv);
    f_color = vec4(c.rgb, c.a * u_alpha);
}
#endif
#endif

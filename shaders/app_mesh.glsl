#version 330
// The app's mesh views (puppet/app/gl/canvas.py): canvas points drawn with the view's
// scale and origin into a target of u_screen pixels.
//   DEPTH    triangles coloured by interpolated depth (blue back -> cyan -> yellow ->
//            red front), nearer in front through the depth buffer; u_range: the depths
//            drawn (lo, hi)
//   WIRE     edges in one colour (u_color)
#if defined VERTEX_SHADER
uniform vec2 u_screen;
uniform float u_scale;
uniform vec2 u_origin;
in vec2 in_pos;
#if defined DEPTH
uniform vec2 u_range;
in float in_depth;
out float v_t;
#endif
void main() {
    vec2 s = in_pos * u_scale + u_origin;
#if defined DEPTH
    v_t = clamp((in_depth - u_range.x) / max(u_range.y - u_range.x, 1e-6), 0.0, 1.0);
    gl_Position = vec4(s.x / u_screen.x * 2.0 - 1.0, 1.0 - s.y / u_screen.y * 2.0, 1.0 - v_t * 1.98 - 0.01, 1.0);
#else
    gl_Position = vec4(s.x / u_screen.x * 2.0 - 1.0, 1.0 - s.y / u_screen.y * 2.0, 0.0, 1.0);
#endif
}
#elif defined FRAGMENT_SHADER
out vec4 f_color;
#if defined DEPTH
in float v_t;
void main() {
    vec3 a = vec3(0.15, 0.25, 0.85), b = vec3(0.1, 0.8, 0.85), c = vec3(0.95, 0.85, 0.15), d = vec3(0.9, 0.15, 0.1);
    vec3 col = v_t < 0.33 ? mix(a, b, v_t / 0.33) : v_t < 0.66 ? mix(b, c, (v_t - 0.33) / 0.33) : mix(c, d, (v_t - 0.66) / 0.34);
    f_color = vec4(col, 1.0);
}
#else
uniform vec4 u_color;
void main() { f_color = u_color; }
#endif
#endif

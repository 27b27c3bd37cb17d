#version 430 core
// Mesh edges as lines of one premultiplied colour (debug wireframe), over the composite.
#if defined VERTEX_SHADER
uniform vec4 u_ndc;  // canvas px -> NDC: pos * u_ndc.xy + u_ndc.zw
in vec2 in_pos;
void main() {
    gl_Position = vec4(in_pos * u_ndc.xy + u_ndc.zw, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform vec4 u_color;
out vec4 f_color;
void main() {
    f_color = u_color;
}
#endif

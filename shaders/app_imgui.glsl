#version 330
// Dear ImGui's draw lists (puppet/app/gl/imgui_renderer.py): window pixels (top-down) to NDC by
// u_scale = (2 / width, 2 / height); vertex colour times the texture (font atlas, images).
#if defined VERTEX_SHADER
uniform vec2 u_scale;
in vec2 in_pos;
in vec2 in_uv;
in vec4 in_color;
out vec2 v_uv;
out vec4 v_color;
void main() {
    v_uv = in_uv;
    v_color = in_color;
    gl_Position = vec4(in_pos.x * u_scale.x - 1.0, 1.0 - in_pos.y * u_scale.y, 0.0, 1.0);
}
#elif defined FRAGMENT_SHADER
uniform sampler2D u_texture;
in vec2 v_uv;
in vec4 v_color;
out vec4 f_color;
void main() {
    f_color = v_color * texture(u_texture, v_uv);
}
#endif

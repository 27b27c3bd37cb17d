#version 430 core
// The compositor's per-layer passes (puppet/render/compositor.py), one variant each:
//   OPAQUE_PASS    every non-empty triangle; keeps fragments with alpha >= ALPHA_OPAQUE;
//                  depth test LEQUAL + write (exact ties: the later triangle wins).
//   KBUFFER_PASS   edge triangles; early depth test LESS against the opaque depth, no
//                  write; keeps fragments with ALPHA_MIN <= alpha < ALPHA_OPAQUE and
//                  inserts them, by depth, into a per-pixel K-entry buffer packed in two
//                  integer colour attachments read back with framebuffer fetch (coherent,
//                  in primitive order); rewrites the pixel as the sorted entries over the
//                  colour found under the first of them (the opaque layer or background).
//   APPEND_PASS    edge triangles, same tests; appends the fragments to per-pixel linked
//                  lists (a node buffer and an image of list heads): the A-buffer.
//   RESOLVE_PASS   edge triangles again, same early test; the first fragment at a pixel
//                  takes its list (and empties the head), sorts it and outputs the
//                  composite, blended over the opaque colour (ONE, ONE_MINUS_SRC_ALPHA).
//   BLEND_PASS     drag previews only (not exact): edge triangles, same early test; the
//                  fragments blended over the frame (ONE, ONE_MINUS_SRC_ALPHA) in drawing
//                  order, unsorted: one cheap pass instead of the K-buffer or A-buffer.
// Injected defines: ALPHA_MIN, ALPHA_OPAQUE, Z_MIN, Z_MAX, K, MAX_FRAGMENTS.
// Every variant has the same vertex shader and `invariant gl_Position`, so every pass
// computes bit-identical window depths: exact ties stay ties from pass to pass.
// Canvas y (down) maps to framebuffer rows by u_ndc; depth d to window depth
// (hi - d) / (hi - lo) - bias with u_depth = (hi, 1 / (hi - lo), bias): 0 = nearest.
#if defined FRAGMENT_SHADER && defined KBUFFER_PASS
#extension GL_EXT_shader_framebuffer_fetch : require
#endif

#if defined VERTEX_SHADER
uniform vec4 u_ndc;    // canvas px -> NDC: pos * u_ndc.xy + u_ndc.zw
uniform vec3 u_depth;  // (hi, 1 / (hi - lo), tie bias of this layer)
in vec2 in_pos;
in float in_depth;
#if !defined RESOLVE_PASS
in vec2 in_uv;
out vec2 v_uv;
#endif
invariant gl_Position;
void main() {
#if !defined RESOLVE_PASS
    v_uv = in_uv;
#endif
    float z = clamp((u_depth.x - in_depth) * u_depth.y - u_depth.z, Z_MIN, Z_MAX);
    gl_Position = vec4(in_pos * u_ndc.xy + u_ndc.zw, 2.0 * z - 1.0, 1.0);
}

#elif defined FRAGMENT_SHADER && defined OPAQUE_PASS
uniform sampler2D u_texture;  // premultiplied RGBA, linear, clamp to edge
in vec2 v_uv;
out vec4 f_color;
void main() {
    vec4 color = texture(u_texture, v_uv);
    if (color.a < ALPHA_OPAQUE) discard;
    f_color = color;
}

#elif defined FRAGMENT_SHADER && defined BLEND_PASS
layout(early_fragment_tests) in;
uniform sampler2D u_texture;
in vec2 v_uv;
out vec4 f_color;
void main() {
    vec4 color = texture(u_texture, v_uv);
    if (color.a < ALPHA_MIN || color.a >= ALPHA_OPAQUE) discard;
    f_color = color;
}

#elif defined FRAGMENT_SHADER && defined KBUFFER_PASS
// Written out for K = 3 with constant indices only (llvmpipe runs indexed arrays lane
// by lane, several times slower); the state is packed into two integer attachments
// (each attachment costs llvmpipe per shaded block, whatever its size).
#if K != 3
#error "the K-buffer pass is written for K = 3"
#endif
layout(early_fragment_tests) in;
uniform sampler2D u_texture;
uniform uint u_frame;  // frame stamp; steps by K + 1 each frame
layout(std430, binding = 0) buffer Counters { uint overflow; uint used; uint lost; };
in vec2 v_uv;
layout(location = 0) inout vec4 f_color;   // the composite
layout(location = 1) inout uvec4 f_colors; // RGBA8: under the entries, entries 0-2
layout(location = 2) inout uvec4 f_depths; // entries' window depths, u_frame + count
// the new fragment c (depth z) sits in slot i; move it before slot j when not behind it
// (at an exact tie it goes in front: the later triangle in drawing order wins)
#define MOVE_UP(i, j) if (at == i && z <= d##j) { e##i = e##j; d##i = d##j; \
                                                  e##j = c; d##j = z; at = j; }
void main() {
    vec4 c = texture(u_texture, v_uv);
    if (c.a < ALPHA_MIN || c.a >= ALPHA_OPAQUE) discard;
    float z = gl_FragCoord.z;
    uvec4 colors = f_colors, depths = f_depths;
    uint n = depths.w - u_frame;  // a stale stamp wraps to a large number
    vec4 under = unpackUnorm4x8(colors.x);
    if (n > uint(K)) {  // the first fragment here this frame
        n = 0u;
        under = f_color;
    }
    vec4 e0 = unpackUnorm4x8(colors.y), e1 = unpackUnorm4x8(colors.z);
    vec4 e2 = unpackUnorm4x8(colors.w), e3 = c;
    float d0 = uintBitsToFloat(depths.x), d1 = uintBitsToFloat(depths.y);
    float d2 = uintBitsToFloat(depths.z), d3 = z;
    if (n == 0u) { e0 = c; d0 = z; }
    if (n == 1u) { e1 = c; d1 = z; }
    if (n == 2u) { e2 = c; d2 = z; }
    int at = int(n);
    MOVE_UP(3, 2)
    MOVE_UP(2, 1)
    MOVE_UP(1, 0)
    n += 1u;
    if (n > uint(K)) {  // full: merge the two farthest (exact unless a later one falls between)
        e2 += (1.0 - e2.a) * e3;
        n = uint(K);
        atomicAdd(overflow, 1u);
    }
    vec4 acc = e0;
    if (n > 1u) acc += (1.0 - acc.a) * e1;
    if (n > 2u) acc += (1.0 - acc.a) * e2;
    f_color = acc + (1.0 - acc.a) * under;
    f_colors = uvec4(packUnorm4x8(under), packUnorm4x8(e0), packUnorm4x8(e1), packUnorm4x8(e2));
    f_depths = uvec4(floatBitsToUint(d0), floatBitsToUint(d1), floatBitsToUint(d2), u_frame + n);
}

#elif defined FRAGMENT_SHADER && defined APPEND_PASS
layout(early_fragment_tests) in;
uniform sampler2D u_texture;
uniform uint u_order;     // drawing position of the layer << 20
uniform uint u_capacity;  // nodes in the buffer
layout(r32ui, binding = 0) uniform uimage2D u_heads;  // node index + 1, 0 = empty
layout(std430, binding = 0) buffer Counters { uint overflow; uint used; uint lost; };
layout(std430, binding = 1) buffer Nodes { uvec4 nodes[]; };  // colour, z, order, next
in vec2 v_uv;
void main() {
    vec4 color = texture(u_texture, v_uv);
    if (color.a < ALPHA_MIN || color.a >= ALPHA_OPAQUE) discard;
    uint index = atomicAdd(used, 1u);
    if (index >= u_capacity) {
        atomicAdd(lost, 1u);
        discard;
    }
    uint next = imageAtomicExchange(u_heads, ivec2(gl_FragCoord.xy), index + 1u);
    nodes[index] = uvec4(packUnorm4x8(color), floatBitsToUint(gl_FragCoord.z),
                         u_order + uint(gl_PrimitiveID), next);
}

#elif defined FRAGMENT_SHADER && defined RESOLVE_PASS
layout(early_fragment_tests) in;
layout(r32ui, binding = 0) uniform uimage2D u_heads;
layout(std430, binding = 0) buffer Counters { uint overflow; uint used; uint lost; };
layout(std430, binding = 1) buffer Nodes { uvec4 nodes[]; };
out vec4 f_color;
void main() {
    uint next = imageAtomicExchange(u_heads, ivec2(gl_FragCoord.xy), 0u);
    if (next == 0u) discard;  // empty, or resolved by an earlier fragment
    uvec4 list[MAX_FRAGMENTS];  // nearest first: smaller z, then larger order
    int n = 0;
    int total = 0;
    while (next != 0u) {
        uvec4 node = nodes[next - 1u];
        next = node.w;
        total += 1;
        float z = uintBitsToFloat(node.y);
        int i = min(n, MAX_FRAGMENTS - 1);
        if (n == MAX_FRAGMENTS) {  // full: keep the nearest MAX_FRAGMENTS
            float zl = uintBitsToFloat(list[i].y);
            if (z > zl || (z == zl && node.z < list[i].z)) continue;
        }
        while (i > 0) {
            float zp = uintBitsToFloat(list[i - 1].y);
            if (zp < z || (zp == z && list[i - 1].z > node.z)) break;
            list[i] = list[i - 1];
            i -= 1;
        }
        list[i] = node;
        n = min(n + 1, MAX_FRAGMENTS);
    }
    if (total > K) atomicAdd(overflow, 1u);
    vec4 acc = vec4(0.0);
    for (int i = 0; i < n; ++i) acc += (1.0 - acc.a) * unpackUnorm4x8(list[i].x);
    f_color = acc;
}
#endif

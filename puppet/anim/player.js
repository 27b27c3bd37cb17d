// puppet's web player: plays the solved frames of one scene (written by puppet/anim/web.py).
// WebGL2, no dependencies. The page holds two data blocks: #puppet-meta (JSON: layers with
// their textures as PNG data URIs, texture coordinates, triangles) and #puppet-frames
// (base64 of key records: int32 layer, int32 frame, float32 cx1, cy1, cx2, cy2 of the
// curve to the layer's next key (NaN: linear), then the layer's int16 x, y (interleaved)
// and depths at that frame; a layer that draws nothing has none). The frames between a
// layer's keys are computed on loading, as Spine's runtimes interpolate a deform timeline
// (puppet/anim/keys.py): a fraction p of the way from one key to the next, linear in time
// or read off the curve's polyline through its points at parameters 0, 0.1, ... 1; each
// code rounded to the nearest.
// Drawing follows puppet's compositor (puppet/render/passes.py, shaders/layer.glsl):
//   1. clear to the background, depth 1;
//   2. opaque pass: every non-empty triangle, depth test LEQUAL + write, fragments with
//      alpha < ALPHA_OPAQUE discarded; window depth (hi - d) / (hi - lo) - i * TIE_BIAS;
//   3. edge pass: the triangles that can be translucent, depth test LESS, no depth write,
//      blended premultiplied over, layers from the farthest to the nearest (mean depth).
//      The compositor sorts those fragments per pixel (K-buffer); here the order is per
//      layer, which differs only where soft edges of two layers overlap each other.
"use strict";
(function () {
  const meta = JSON.parse(document.getElementById("puppet-meta").textContent);
  const ALPHA_MIN = 0.5 / 255, ALPHA_OPAQUE = 254.5 / 255, TIE_BIAS = Math.pow(2, -16);
  const Z_MIN = Math.pow(2, -16), Z_MAX = 1 - Math.pow(2, -16);

  function bytes(b64) {
    const s = atob(b64.replace(/\s+/g, ""));
    const out = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
    return out;
  }
  const N = meta.count, NV = meta.vertices, STRIDE = 3 * NV;  // int16 per frame

  // the fraction at time t from a key at ta to the next at tb (curve: [cx1, cy1, cx2, cy2] or null)
  function percent(t, ta, tb, curve) {
    if (!curve) return (t - ta) / (tb - ta);
    const [cx1, cy1, cx2, cy2] = curve;
    let xa = ta, ya = 0;
    for (let k = 1; k <= 10; k++) {
      const s = k / 10, u = 1 - s, b1 = 3 * u * u * s, b2 = 3 * u * s * s, b3 = s * s * s;
      const x = k === 10 ? tb : u * u * u * ta + b1 * cx1 + b2 * cx2 + b3 * tb;
      const y = k === 10 ? 1 : b1 * cy1 + b2 * cy2 + b3;
      if (x >= t) return x > xa ? ya + (t - xa) / (x - xa) * (y - ya) : y;
      xa = x; ya = y;
    }
    return 1;
  }

  // every frame's codes (per frame: every layer's x, y, then every layer's depth) from the keys
  function frameData() {
    const raw = bytes(document.getElementById("puppet-frames").textContent);
    const view = new DataView(raw.buffer);
    const keys = meta.layers.map(() => []);
    for (let o = 0; o < raw.length;) {
      const li = view.getInt32(o, true), n = meta.layers[li].n;
      const c = [0, 1, 2, 3].map((k) => view.getFloat32(o + 8 + 4 * k, true));
      keys[li].push({f: view.getInt32(o + 4, true), curve: isNaN(c[0]) ? null : c,
                     q: new Int16Array(raw.buffer, o + 24, 3 * n)});
      o += 24 + 6 * n;
    }
    const data = new Int16Array(N * STRIDE);
    meta.layers.forEach((L, li) => {
      const ks = keys[li], n = L.n;
      for (let j = 0; j < ks.length; j++) {
        const a = ks[j], b = ks[j + 1] || a, last = j + 1 >= ks.length;
        for (let f = a.f; f <= (last ? a.f : b.f - 1); f++) {
          const p = f === a.f ? 0 : percent(f / meta.fps, a.f / meta.fps, b.f / meta.fps, a.curve);
          const xy = f * STRIDE + 2 * L.base, d = f * STRIDE + 2 * NV + L.base;
          for (let k = 0; k < 2 * n; k++) data[xy + k] = Math.round(a.q[k] + p * (b.q[k] - a.q[k]));
          for (let k = 0; k < n; k++) data[d + k] = Math.round(a.q[2 * n + k] + p * (b.q[2 * n + k] - a.q[2 * n + k]));
        }
      }
    });
    return data;
  }
  const data = frameData();
  const canvas = document.getElementById("puppet-canvas");
  canvas.puppetFrames = data;  // every frame's codes, for tests (tests/anim/test_web_keys.py)
  const gl = canvas.getContext("webgl2", {antialias: false, depth: true, alpha: true,
                                          premultipliedAlpha: true, preserveDrawingBuffer: true});
  const status = document.getElementById("puppet-status");
  if (!gl) { status.textContent = "this browser has no WebGL2"; return; }

  const VS = `#version 300 es
  uniform vec4 u_ndc;   // canvas px -> NDC
  uniform vec4 u_q;     // position: q * u_q.xy + u_q.zw (int16 -> canvas px)
  uniform vec3 u_depth; // (hi, 1 / (hi - lo), tie bias of this layer)
  uniform float u_dq;   // depth: q * u_dq
  in vec2 in_q; in float in_dq; in vec2 in_uv;
  out vec2 v_uv;
  void main() {
    v_uv = in_uv;
    vec2 pos = in_q * u_q.xy + u_q.zw;
    float z = clamp((u_depth.x - in_dq * u_dq) * u_depth.y - u_depth.z, ${Z_MIN}, ${Z_MAX});
    gl_Position = vec4(pos * u_ndc.xy + u_ndc.zw, 2.0 * z - 1.0, 1.0);
  }`;
  const FS = (edge) => `#version 300 es
  precision highp float;
  uniform sampler2D u_texture;  // premultiplied
  in vec2 v_uv; out vec4 f_color;
  void main() {
    vec4 c = texture(u_texture, v_uv);
    ${edge ? `if (c.a < ${ALPHA_MIN} || c.a >= ${ALPHA_OPAQUE}) discard;`
           : `if (c.a < ${ALPHA_OPAQUE}) discard;`}
    f_color = c;
  }`;

  function program(vs, fs) {
    const p = gl.createProgram();
    for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
      const s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      gl.attachShader(p, s);
    }
    gl.bindAttribLocation(p, 0, "in_q");
    gl.bindAttribLocation(p, 1, "in_dq");
    gl.bindAttribLocation(p, 2, "in_uv");
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
    const u = {};
    for (const name of ["u_ndc", "u_q", "u_depth", "u_dq", "u_texture"]) u[name] = gl.getUniformLocation(p, name);
    return {p, u};
  }
  const passes = {opaque: program(VS, FS(false)), edge: program(VS, FS(true))};

  const frames = gl.createBuffer();  // every frame, drawn by moving the attribute offsets
  gl.bindBuffer(gl.ARRAY_BUFFER, frames);
  gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);

  const layers = meta.layers.map((L) => {
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const uv = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, uv);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(bytes(L.uv).buffer), gl.STATIC_DRAW);
    gl.enableVertexAttribArray(2);
    gl.vertexAttribPointer(2, 2, gl.FLOAT, false, 0, 0);
    gl.enableVertexAttribArray(0);
    gl.enableVertexAttribArray(1);
    const ibo = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ibo);
    const tri = new Uint32Array(bytes(L.triangles).buffer);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, tri, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return {vao, base: L.base, n: L.n, opaque: L.opaque, edge: L.edge, texture: null, src: L.texture};
  });

  async function loadTextures() {
    await Promise.all(layers.map(async (L) => {
      const blob = await (await fetch(L.src)).blob();
      const bmp = await createImageBitmap(blob, {premultiplyAlpha: "premultiply", colorSpaceConversion: "none"});
      L.texture = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, L.texture);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, bmp);
      for (const [k, v] of [[gl.TEXTURE_MIN_FILTER, gl.LINEAR], [gl.TEXTURE_MAG_FILTER, gl.LINEAR],
                            [gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE], [gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE]])
        gl.texParameteri(gl.TEXTURE_2D, k, v);
    }));
  }

  // per frame: the depth window of the drawn layers and their order by mean depth
  const windows = [];
  for (let f = 0; f < N; f++) {
    let lo = Infinity, hi = -Infinity;
    const means = layers.map((L) => {
      if (!L.opaque) return 0;
      let sum = 0;
      const d0 = f * STRIDE + 2 * NV + L.base;
      for (let k = 0; k < L.n; k++) {
        const d = data[d0 + k] * meta.depthStep;
        sum += d; lo = Math.min(lo, d); hi = Math.max(hi, d);
      }
      return L.n ? sum / L.n : 0;
    });
    if (lo > hi) { lo = hi = 0; }
    const margin = Math.max(0.05 * (hi - lo), 0.5);
    const top = hi + margin, inv = 1 / (hi + margin - (lo - margin));
    const order = layers.map((L, i) => i).filter((i) => layers[i].opaque)
      .sort((a, b) => ((top - means[b]) * inv - b * TIE_BIAS) - ((top - means[a]) * inv - a * TIE_BIAS));
    windows.push({top, inv, order});  // farthest first
  }

  const [cw, ch] = meta.canvas;
  function draw(f) {
    const w = windows[f];
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, canvas.width, canvas.height);
    const bg = meta.background;
    gl.clearColor(bg[0] * bg[3], bg[1] * bg[3], bg[2] * bg[3], bg[3]);
    gl.clearDepth(1);
    gl.depthMask(true);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    const q = meta.quant;
    for (const [name, func] of [["opaque", gl.LEQUAL], ["edge", gl.LESS]]) {
      const {p, u} = passes[name];
      gl.useProgram(p);
      gl.uniform4f(u.u_ndc, 2 / cw, -2 / ch, -1, 1);
      gl.uniform4f(u.u_q, q[0], q[1], q[2], q[3]);
      gl.uniform1f(u.u_dq, meta.depthStep);
      gl.uniform1i(u.u_texture, 0);
      gl.depthFunc(func);
      if (name === "edge") {
        gl.depthMask(false);
        gl.enable(gl.BLEND);
        gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
      } else {
        gl.disable(gl.BLEND);
      }
      for (const i of w.order) {
        const L = layers[i];
        const count = name === "edge" ? L.edge : L.opaque;
        if (!count) continue;
        gl.uniform3f(u.u_depth, w.top, w.inv, i * TIE_BIAS);
        gl.bindVertexArray(L.vao);
        gl.bindBuffer(gl.ARRAY_BUFFER, frames);
        gl.vertexAttribPointer(0, 2, gl.SHORT, false, 0, 2 * (f * STRIDE + 2 * L.base));
        gl.vertexAttribPointer(1, 1, gl.SHORT, false, 0, 2 * (f * STRIDE + 2 * NV + L.base));
        gl.activeTexture(gl.TEXTURE0);
        gl.bindTexture(gl.TEXTURE_2D, L.texture);
        // opaque: every drawn triangle (the index buffer's first L.opaque * 3); edge: the last L.edge * 3
        const first = name === "edge" ? L.opaque : 0;
        gl.drawElements(gl.TRIANGLES, 3 * count, gl.UNSIGNED_INT, 4 * 3 * first);
      }
    }
    gl.bindVertexArray(null);
    gl.disable(gl.BLEND);
  }

  // -- controls --------------------------------------------------------------------
  const play = document.getElementById("puppet-play"), scrub = document.getElementById("puppet-scrub");
  const loop = document.getElementById("puppet-loop"), label = document.getElementById("puppet-time");
  scrub.max = String(N - 1);
  let frame = 0, playing = false, t0 = 0, f0 = 0, shown = -1;

  function show(f) {
    frame = f;
    if (f === shown) return;
    shown = f;
    draw(f);
    scrub.value = String(f);
    const t = meta.start + f / meta.fps;
    label.textContent = `${t.toFixed(3)} s  frame ${f + 1}/${N}`;
    document.body.dataset.frame = String(f);
  }
  function setPlaying(on) {
    playing = on;
    play.textContent = on ? "Pause" : "Play";
    if (on) {
      if (frame >= N - 1 && !loop.checked) frame = 0;
      t0 = performance.now(); f0 = frame;
      schedule();
    }
  }
  function tick() {
    if (!playing) return;
    // the clock, not the callback's frame timestamp (which may lag it, e.g. headless)
    let f = f0 + Math.floor((performance.now() - t0) * meta.fps / 1000);
    if (f >= N) {
      if (loop.checked) f %= N;
      else { show(N - 1); setPlaying(false); return; }
    }
    show(f);
    schedule();
  }
  // the next tick on the next animation frame, or after one frame time when no animation
  // frame comes (a headless browser under virtual time): whichever is first
  let pending = false;
  function schedule() {
    if (pending) return;
    pending = true;
    const go = () => { if (pending) { pending = false; tick(); } };
    requestAnimationFrame(go);
    setTimeout(go, 1000 / meta.fps);
  }
  function fromHash() {  // #t=SECONDS: paused on that frame
    const m = /(?:^#|&)t=([0-9.eE+-]+)/.exec(location.hash);
    if (!m) return false;
    const t = parseFloat(m[1]);
    if (!isFinite(t)) return false;
    setPlaying(false);
    show(Math.min(N - 1, Math.max(0, Math.round((t - meta.start) * meta.fps))));
    return true;
  }
  play.onclick = () => setPlaying(!playing);
  scrub.oninput = () => { setPlaying(false); show(parseInt(scrub.value, 10)); };
  window.addEventListener("hashchange", fromHash);
  window.addEventListener("keydown", (e) => {
    if (e.key === " ") { e.preventDefault(); setPlaying(!playing); }
    else if (e.key === "ArrowRight") { setPlaying(false); show(Math.min(N - 1, frame + 1)); }
    else if (e.key === "ArrowLeft") { setPlaying(false); show(Math.max(0, frame - 1)); }
  });

  loadTextures().then(() => {
    status.textContent = "";
    if (!fromHash()) { show(0); setPlaying(true); }
    document.body.dataset.ready = "1";
  }).catch((e) => { status.textContent = "cannot play: " + e; });
})();

// puppet dressroom: the shopper's page. The mannequin, then the worn garments in draw
// order (category, then order), each drawn "over" on a 2D canvas. The outfit is kept in
// the address: #outfit=NAME,NAME[&tuck=1]. A garment's picture and depth are loaded when
// it is first worn, a thumbnail when it comes near the screen (a folder room of
// thousands loads what it shows).
(() => {
  "use strict";
  const doc = document, body = doc.body;
  const meta = JSON.parse(doc.getElementById("room-meta").textContent);
  const [W, H] = meta.canvas, garments = meta.garments;
  const canvas = doc.getElementById("room-canvas"), ctx = canvas.getContext("2d");
  const status = doc.getElementById("room-status"), tuckBox = doc.getElementById("room-tuck");
  const ghost = doc.getElementById("room-ghost");
  const byName = new Map(garments.map((g, i) => [g.name, i]));
  const HINT = "Click or drag a garment onto the mannequin to put it on; click it there to take it off.";
  let worn = new Set(), tuck = false, mannequin = null, draws = 0;
  const images = [], loading = new Map();  // garment -> {image, depth} once loaded; its loading

  // the PNGs' bytes as they are (no colour management: the depth images hold codes); a
  // folder room opened from the disk (file://) cannot fetch: its pictures are shown, but
  // the browser does not let the page read them back (tuck in, clicks on the mannequin)
  const decoded = async (src) => {
    let blob;
    try {
      blob = await (await fetch(src)).blob();
    } catch (e) {
      const im = new Image();
      im.src = src;
      await im.decode();
      return im;
    }
    return createImageBitmap(blob, { colorSpaceConversion: "none" });
  };
  const pixels = (im) => {  // the image's RGBA bytes (an offscreen canvas of its size)
    const c = doc.createElement("canvas");
    c.width = im.width; c.height = im.height;
    const g = c.getContext("2d", { willReadFrequently: true });
    g.drawImage(im, 0, 0);
    return g.getImageData(0, 0, c.width, c.height);
  };
  function load(i) {
    if (!loading.has(i)) {
      loading.set(i, Promise.all([decoded(garments[i].image), decoded(garments[i].depth)])
        .then(([image, depth]) => { images[i] = { image, depth }; },
              (e) => { loading.delete(i); throw e; }));  // tried again next time
    }
    return loading.get(i);
  }
  const readable = (i) => { try { data(i); return true; } catch (e) { return false; } };
  const cache = new Map();  // garment -> {alpha, depth}: read from its images when first needed
  function data(i) {
    if (!cache.has(i)) {
      const g = garments[i], a = pixels(images[i].image).data, d = pixels(images[i].depth).data;
      const [low, steps] = meta.depthCode, n = g.size[0] * g.size[1];
      const alpha = new Uint8Array(n), depth = new Float32Array(n);
      for (let k = 0; k < n; k++) {
        alpha[k] = a[4 * k + 3];
        depth[k] = d[4 * k + 2] ? (d[4 * k] * 256 + d[4 * k + 1]) / steps + low : NaN;
      }
      cache.set(i, { alpha, depth });
    }
    return cache.get(i);
  }

  // -- the outfit ------------------------------------------------------------------------
  function put(i, set = worn) {  // wear i: it replaces the garment of its category (accessories stack)
    const cat = garments[i].category;
    if (cat !== "accessory") for (const j of [...set]) if (garments[j].category === cat) set.delete(j);
    set.add(i);
    return set;
  }
  const wornOf = (cat, set = worn) => [...set].filter((i) => garments[i].category === cat);
  const names = () => [...worn].sort((a, b) => a - b).map((i) => garments[i].name);

  // A tucked top is hidden where its depth is below the bottom's: where the bottom shows,
  // and inside the waistband (in each column, below the bottom's first row, against the
  // bottom's depth on that row). Returns the top's image with those pixels clear.
  function tucked(top, bottom) {
    const t = garments[top], b = garments[bottom], td = data(top), bd = data(bottom);
    const [tw, th] = t.size, [bw, bh] = b.size, img = pixels(images[top].image);
    for (let x = 0; x < tw; x++) {
      const bx = x + t.at[0] - b.at[0];
      let edge = -1;
      if (bx >= 0 && bx < bw) for (let y = 0; y < bh && edge < 0; y++) if (bd.alpha[y * bw + bx] > 0) edge = y;
      if (edge < 0) continue;
      for (let y = Math.max(0, edge + b.at[1] - t.at[1]); y < th; y++) {
        const by = y + t.at[1] - b.at[1], k = y * tw + x;
        const shows = by < bh && bd.alpha[by * bw + bx] > 0;
        if (td.depth[k] < bd.depth[(shows ? by : edge) * bw + bx]) img.data[4 * k + 3] = 0;
      }
    }
    const c = doc.createElement("canvas");
    c.width = tw; c.height = th;
    c.getContext("2d").putImageData(img, 0, 0);
    return c;
  }

  function draw(set = worn) {  // the outfit (or a preview of one while a garment is dragged over the mannequin)
    ctx.clearRect(0, 0, W, H);
    ctx.drawImage(mannequin, 0, 0);
    const order = [...set].sort((a, b) => a - b), top = wornOf("top", set)[0], bottom = wornOf("bottom", set)[0];
    for (const i of order) {
      const g = garments[i];
      let picture = images[i].image;
      if (i === top && tuck && bottom !== undefined) {
        try {
          picture = tucked(top, bottom);
        } catch (e) {  // a folder room opened from the disk: its pictures cannot be read back
          status.textContent = "Tucking in needs the room served over HTTP (" + e.name + ").";
        }
      }
      ctx.drawImage(picture, g.at[0], g.at[1]);
    }
    body.dataset.shown = [...set].sort((a, b) => a - b).map((i) => garments[i].name).join(",");
    if (set !== worn) return;
    tuckBox.disabled = top === undefined || bottom === undefined;
    for (const el of doc.querySelectorAll(".room-item")) {
      el.classList.toggle("worn", worn.has(+el.dataset.index));
      el.setAttribute("aria-pressed", String(worn.has(+el.dataset.index)));
    }
    body.dataset.outfit = names().join(",");
    body.dataset.draws = String(++draws);
  }

  let asked = 0;
  async function show(set = worn) {  // draw once its garments are loaded (unless asked for another since)
    const token = ++asked;
    try {
      await Promise.all([...set].map(load));
    } catch (e) {
      if (token === asked) status.textContent = "A garment's picture could not be loaded: " + e;
      return;
    }
    if (token === asked) draw(set);
  }

  function changed() {  // the outfit changed here: draw it and keep the address up to date
    const hash = "#outfit=" + names().map(encodeURIComponent).join(",") + (tuck ? "&tuck=1" : "");
    history.replaceState(null, "", hash);
    return show();
  }

  function fromAddress() {  // #outfit=a,b[&tuck=1]: exactly those garments on
    const fields = new Map(location.hash.replace(/^#/, "").split("&").filter(Boolean).map((kv) => {
      const at = kv.indexOf("=");
      return at < 0 ? [kv, ""] : [kv.slice(0, at), kv.slice(at + 1)];
    }));
    worn = new Set();
    const unknown = [];
    for (const part of (fields.get("outfit") || "").split(",").filter(Boolean)) {
      let name;
      try { name = decodeURIComponent(part); } catch (e) { name = part; }
      if (byName.has(name)) put(byName.get(name)); else unknown.push(name);
    }
    tuck = fields.get("tuck") === "1";
    tuckBox.checked = tuck;
    status.textContent = unknown.length ? "No garment named " + unknown.join(", ") + " in this room." : HINT;
    return show();
  }

  // -- the shelf: thumbnails by category; a click toggles, a drag onto the mannequin wears --
  function shelf() {
    const root = shelfEl;
    for (const cat of meta.categories) {
      const items = garments.map((g, i) => [g, i]).filter(([g]) => g.category === cat);
      if (!items.length) continue;
      const sec = doc.createElement("section"), h = doc.createElement("h2"), row = doc.createElement("div");
      sec.className = "room-category"; sec.dataset.category = cat; h.textContent = cat; row.className = "room-items";
      for (const [g, i] of items) {
        const item = doc.createElement("div"), label = doc.createElement("span");
        item.className = "room-item"; item.dataset.index = String(i); item.dataset.name = g.name;
        item.title = g.name; label.textContent = g.name;
        item.tabIndex = 0; item.setAttribute("role", "button"); item.setAttribute("aria-pressed", "false");
        item.append(picture(g), label);
        item.addEventListener("pointerdown", (e) => press(e, i));
        item.addEventListener("keydown", (e) => {  // the keyboard: Enter or Space puts on / takes off
          if (e.key !== "Enter" && e.key !== " ") return;
          e.preventDefault();
          if (worn.has(i)) worn.delete(i); else put(i);
          changed();
        });
        row.append(item);
      }
      sec.append(h, row);
      root.append(sec);
    }
  }

  // a garment's thumbnail: its picture (one file), or its cell on a sheet of thumbnails
  // (the folder form: one sheet of 64 serves a screenful), the sheet shown through the cell
  function picture(g) {
    const t = g.thumb;
    if (t && typeof t === "object") {
      const box = doc.createElement("span"), cut = doc.createElement("span"), img = doc.createElement("img");
      box.className = "room-thumb-box"; cut.className = "room-thumb"; img.className = "room-sheet";
      img.alt = ""; img.draggable = false;
      const m = Math.max(t.size[0], t.size[1], 1), px = (v) => String(v / m);
      cut.style.setProperty("--w", px(t.size[0])); cut.style.setProperty("--h", px(t.size[1]));
      cut.style.setProperty("--x", px(t.at[0])); cut.style.setProperty("--y", px(t.at[1]));
      cut.style.setProperty("--sw", px(t.sheetSize[0])); cut.style.setProperty("--sh", px(t.sheetSize[1]));
      img.dataset.src = t.sheet;
      cut.dataset.sheet = "1";  // the cell is watched (the sheet behind it is mostly clipped away)
      near.observe(cut);
      cut.append(img);
      box.append(cut);
      return box;
    }
    const img = doc.createElement("img"), src = g.thumb || g.image;
    img.alt = ""; img.draggable = false;
    if (src.startsWith("data:")) img.src = src;  // in the page already: shown at once
    else { img.dataset.src = src; near.observe(img); }
    return img;
  }

  // thumbnails load when they come within 100 px of the shelf's view (their src set then):
  // the shelf scrolls on its own beside the mannequin, with the page below it on a phone
  const shelfEl = doc.getElementById("room-shelf");
  const near = new IntersectionObserver((entries) => {
    for (const e of entries) {
      if (!e.isIntersecting) continue;
      const img = e.target.dataset.sheet ? e.target.firstChild : e.target;
      img.src = img.dataset.src;
      near.unobserve(e.target);
    }
  }, { root: getComputedStyle(shelfEl).overflowY === "auto" ? shelfEl : null, rootMargin: "100px" });

  const SLOP = 6;  // px a press may move and still be a click
  let held = null;  // {i, x, y, dragging}
  function press(e, i) {
    if (e.button > 0) return;
    e.preventDefault();
    held = { i, x: e.clientX, y: e.clientY, dragging: false, over: false };
  }
  window.addEventListener("pointermove", (e) => {
    if (!held) return;
    if (!held.dragging && Math.hypot(e.clientX - held.x, e.clientY - held.y) > SLOP) {
      held.dragging = true;
      ghost.src = garments[held.i].image;
      ghost.style.display = "block";
    }
    if (!held.dragging) return;
    ghost.style.left = e.clientX + "px"; ghost.style.top = e.clientY + "px";
    const over = onCanvas(e.clientX, e.clientY);
    if (over !== held.over) {  // over the mannequin: shown worn until the drop (or the way out)
      held.over = over;
      show(over ? put(held.i, new Set(worn)) : worn);
    }
  });
  window.addEventListener("pointerup", (e) => {
    if (!held) return;
    const { i, dragging, over } = held;
    held = null;
    ghost.style.display = "none";
    if (!dragging) {
      if (worn.has(i)) worn.delete(i); else put(i);
      changed();
    } else if (onCanvas(e.clientX, e.clientY)) {
      put(i);
      changed();
    } else if (over) show();  // dropped elsewhere: the preview goes
  });
  window.addEventListener("pointercancel", () => {
    if (held && held.over) show();
    held = null;
    ghost.style.display = "none";
  });

  function onCanvas(x, y) {
    const r = canvas.getBoundingClientRect();
    return x >= r.left && x < r.right && y >= r.top && y < r.bottom;
  }

  canvas.addEventListener("click", (e) => {  // a click on a worn garment takes it off
    const r = canvas.getBoundingClientRect();
    const x = Math.floor((e.clientX - r.left) * W / r.width), y = Math.floor((e.clientY - r.top) * H / r.height);
    const front = [...worn].sort((a, b) => b - a).find((i) => {
      const g = garments[i], gx = x - g.at[0], gy = y - g.at[1];
      if (!images[i] || !readable(i)) return false;  // still loading, or a folder room from the disk
      return gx >= 0 && gy >= 0 && gx < g.size[0] && gy < g.size[1] && data(i).alpha[gy * g.size[0] + gx] > 0;
    });
    if (front !== undefined) { worn.delete(front); changed(); }
  });

  tuckBox.addEventListener("change", () => { tuck = tuckBox.checked; changed(); });
  doc.getElementById("room-undress").addEventListener("click", () => { worn = new Set(); changed(); });
  doc.getElementById("room-download").addEventListener("click", () => {
    canvas.toBlob((blob) => {
      const a = doc.createElement("a");
      a.href = URL.createObjectURL(blob);
      a.download = (names().join("+") || "mannequin") + ".png";
      doc.body.append(a); a.click(); a.remove();
      setTimeout(() => URL.revokeObjectURL(a.href), 1000);
    }, "image/png");
  });
  window.addEventListener("hashchange", fromAddress);

  // the address's garments start loading beside the mannequin (the first outfit needs both)
  for (const part of ((/(?:^#|&)outfit=([^&]*)/.exec(location.hash) || [])[1] || "").split(",")) {
    let name;
    try { name = decodeURIComponent(part); } catch (e) { name = part; }
    if (byName.has(name)) load(byName.get(name)).catch(() => {});  // a failure is said by fromAddress
  }
  decoded(meta.mannequin).then((m) => {
    mannequin = m;
    shelf();
    return fromAddress();
  }).then(() => {
    body.dataset.firstDrawMs = performance.now().toFixed(1);
    body.dataset.ready = "1";
  }, (err) => { status.textContent = "This room could not be opened: " + err; });
})();

// rgs-view's page: talks to the server over the WebSocket of view/PROTOCOL.md, draws the frames it returns,
// turns mouse, keyboard and touch input into cameras, and shows the server's statistics. Plain JavaScript, no
// dependencies: the server embeds this file in its binary.
//
// Cameras are kept in the INRIA 3DGS cameras.json convention throughout (the protocol's): `rotation` is
// camera-to-world, given as its 3 rows, so its COLUMNS are the camera axes in world coordinates: column 0 =
// right (x), column 1 = down (y), column 2 = forward (z) (COLMAP: x right, y down, z forward); `position` is the
// camera centre. The page holds a camera as {pos, right, down, fwd} (right × down = fwd) plus the vertical field
// of view and the distance to the orbit target (target = pos + dist·fwd). Orbit and fly turn these axes about
// the world "up" (−down of the starting camera, or −y, the scenes' up, without one) and about the camera's right
// axis.
//
// Test hook (tests/view/test_view_browser.py drives the page through it; every call is safe before connect):
//   window.rgsView.connected            true while the WebSocket is open and hello has arrived
//   window.rgsView.frameCount           frames drawn so far
//   window.rgsView.hello                the server's hello message (null before it)
//   window.rgsView.errors               error messages received (array of the server's objects)
//   window.rgsView.lastFrame()          {seq, width, height, refine, preset, images:[{role, encoding, bytes}], stats,
//                                        psnr, mse, diff_max, latency_ms, digest (FNV-1a of the image bytes,
//                                        hex), camera (the view's camera as sent), quality, scale, max_mbps
//                                        (the server's rate choice and budget), mbps (received, last second)}
//                                        or null
//   window.rgsView.frameLog()           the last 100 frames drawn, [{seq, width, height}]
//   window.rgsView.camera()             the current camera, INRIA object (position, rotation, fx, fy, width,
//                                        height) at the size a still frame is rendered at (resolution scale)
//   window.rgsView.target()             the orbit target, [x, y, z] (orbit keeps the distance to it)
//   window.rgsView.mode()               'orbit' or 'fly'
//   window.rgsView.setCamera(cam, {exact})  jumps to an INRIA camera; exact: render exactly it (its size and
//                                        focal lengths, numbers sent as given) until the next input; otherwise
//                                        its pose and vertical field of view at the window's size. Returns the
//                                        seq of the view it sends (sent at once, not throttled).
//   window.rgsView.setOptions({preset, encoding, quality, background:[r,g,b], compare, diffScale, scale,
//                              motionScale, maxMbps, mode, fovY, split})   the panel's settings
//   window.rgsView.waitForFrame(seq, timeoutMs)  Promise of lastFrame() once a frame of seq ≥ `seq` is drawn
//   window.rgsView.requestLossless({camera, pixels})  Promise of {seq, width, height, png (data URL),
//                                        rgb (base64 of width·height·3 bytes, with pixels: true)}: a lossless
//                                        frame of `camera` (exact, as setCamera's) or of the current view at
//                                        full resolution (scale 1), decoded by the browser (createImageBitmap,
//                                        no colour conversion) and drawn as on screen (compare: split drawn)
//   window.rgsView.record               {start(), stop(), add(), clear(), cameras() → INRIA array, json()
//                                        → the cameras.json text, replay() → Promise, recording}
//   window.rgsView.split                the compare slider's position, 0..1 (left of it: scene A)
(() => {
  'use strict';

  const $ = (id) => document.getElementById(id);
  const MAX_IN_FLIGHT = 1;      // views sent whose frame has not arrived: the newest view goes next
  const STILL_MS = 150;         // full resolution after this long without input
  const FRAME_TIMEOUT_MS = 10000;
  const PING_MS = 20000;        // the server closes a socket that sends nothing for its idle timeout (120 s)

  // ---- vectors -------------------------------------------------------------------------------------------
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => Math.hypot(a[0], a[1], a[2]);
  const normalize = (a) => { const n = norm(a) || 1; return [a[0] / n, a[1] / n, a[2] / n]; };
  // v turned by angle t about unit axis k (Rodrigues).
  const rotate = (v, k, t) => {
    const c = Math.cos(t), s = Math.sin(t), kv = cross(k, v), d = dot(k, v) * (1 - c);
    return [v[0] * c + kv[0] * s + k[0] * d, v[1] * c + kv[1] * s + k[1] * d, v[2] * c + kv[2] * s + k[2] * d];
  };
  const deg = (r) => r * 180 / Math.PI, rad = (d) => d * Math.PI / 180;
  const isVec3 = (v) => Array.isArray(v) && v.length === 3 && v.every(Number.isFinite);

  // ---- state ---------------------------------------------------------------------------------------------
  const cam = { pos: [0, 0, -4], right: [1, 0, 0], down: [0, 1, 0], fwd: [0, 0, 1], dist: 4, fovY: 50 };
  let worldUp = [0, -1, 0];
  let sceneRadius = 1;
  let pinned = null;            // exact INRIA camera set through setCamera(.., {exact: true})
  const opts = {
    preset: 'fastest', encoding: 'jpeg', quality: 85, background: [0, 0, 0], compare: 'off', diffScale: 32,
    scale: 1, motionScale: 0.5, maxMbps: 0, mode: 'orbit',
  };
  let hello = null;
  let ws = null;
  let connected = false;
  let fatalError = null;
  let seq = 0;                  // last seq sent
  let answered = 0;             // newest seq whose frame (or non-fatal error) arrived
  let drawnSeq = -1;            // newest seq drawn
  const sent = new Map();       // seq → {t, camera}
  let lastSentKey = '';
  let lastInput = -1e9;
  let hold = 0;                 // > 0 while a lossless request is out: the interactive loop sends nothing
  let frameCount = 0;
  let lastFrame = null;
  let bitmaps = null;           // the frame on screen: {a, b, diff}
  let split = 0.5;
  const frameTimes = [];        // arrival times of the last second's frames
  const frameLog = [];          // the last 100 frames drawn: {seq, width, height}
  let bytesTotal = 0;
  const received = [];          // the last second's frame messages: {t, bytes}
  const waiters = [];           // {seq, resolve, reject, timer}
  const errors = [];

  // ---- camera conversions --------------------------------------------------------------------------------
  const rotationRows = (c) => [
    [c.right[0], c.down[0], c.fwd[0]],
    [c.right[1], c.down[1], c.fwd[1]],
    [c.right[2], c.down[2], c.fwd[2]],
  ];
  function orthonormalize() {
    cam.fwd = normalize(cam.fwd);
    cam.right = normalize(cross(cam.down, cam.fwd));
    cam.down = cross(cam.fwd, cam.right);
  }
  // Loads the pose of an INRIA camera; the orbit target is where the view ray passes the scene centre.
  function poseFromInria(c) {
    const r = c.rotation;
    cam.pos = c.position.slice();
    cam.right = [r[0][0], r[1][0], r[2][0]];
    cam.down = [r[0][1], r[1][1], r[2][1]];
    cam.fwd = [r[0][2], r[1][2], r[2][2]];
    orthonormalize();
    cam.fovY = deg(2 * Math.atan(c.height / (2 * c.fy)));
    const centre = hello && hello.scenes && hello.scenes[0] ? hello.scenes[0].center : null;
    const along = centre ? dot(sub(centre, cam.pos), cam.fwd) : 0;
    cam.dist = along > sceneRadius * 0.05 ? along : sceneRadius;
  }
  function validInria(c) {
    return c && isVec3(c.position) && Array.isArray(c.rotation) && c.rotation.length === 3 &&
      c.rotation.every(isVec3) && c.fx > 0 && c.fy > 0 && c.width >= 1 && c.height >= 1;
  }

  // Size of the frame for a resolution scale: the window in device pixels, scaled, within the server's limits.
  function frameSize(scale) {
    const dpr = window.devicePixelRatio || 1;
    let w = Math.max(1, Math.round(window.innerWidth * dpr * scale));
    let h = Math.max(1, Math.round(window.innerHeight * dpr * scale));
    const mw = hello ? hello.max_width : 7680, mh = hello ? hello.max_height : 4320;
    const f = Math.min(1, mw / w, mh / h);
    return [Math.max(1, Math.floor(w * f)), Math.max(1, Math.floor(h * f))];
  }
  // The current camera as an INRIA object (no id/img_name) at resolution `scale`.
  function currentCamera(scale) {
    if (pinned) {
      const s = scale;
      if (s === 1) return JSON.parse(JSON.stringify(pinned));
      const w = Math.max(1, Math.round(pinned.width * s)), h = Math.max(1, Math.round(pinned.height * s));
      return { position: pinned.position.slice(), rotation: pinned.rotation.map((r) => r.slice()),
        fx: pinned.fx * w / pinned.width, fy: pinned.fy * h / pinned.height, width: w, height: h };
    }
    const [w, h] = frameSize(scale);
    const f = h / (2 * Math.tan(rad(cam.fovY) / 2));
    return { position: cam.pos.slice(), rotation: rotationRows(cam), fx: f, fy: f, width: w, height: h };
  }

  // ---- the connection ------------------------------------------------------------------------------------
  function wsUrl() {
    const token = new URLSearchParams(location.search).get('token');
    const proto = location.protocol === 'https:' ? 'wss:' : 'ws:';
    return `${proto}//${location.host}/ws` + (token ? `?token=${encodeURIComponent(token)}` : '');
  }
  let retryMs = 1000;
  // A still camera sends no views: pings keep the connection from counting as idle.
  setInterval(() => {
    if (ws && ws.readyState === WebSocket.OPEN && connected) ws.send('{"type":"ping"}');
  }, PING_MS);
  function connect() {
    setConn('connecting', 'connecting…');
    try {
      ws = new WebSocket(wsUrl());
    } catch (e) {
      overlay(`cannot connect: ${e.message}`);
      return;
    }
    ws.binaryType = 'arraybuffer';
    ws.onmessage = (ev) => {
      if (typeof ev.data === 'string') onText(ev.data); else onFrame(ev.data);
    };
    ws.onclose = (ev) => {
      connected = false;
      api.connected = false;
      ws = null;
      for (const w of waiters.splice(0)) { clearTimeout(w.timer); w.reject(new Error('connection closed')); }
      setConn('off', 'offline');
      if (fatalError) {
        overlay(`server: ${fatalError}`);
        return;
      }
      if (ev.code !== 1013) overlay(`disconnected (${ev.code}); retrying…`);
      setTimeout(connect, retryMs);
      retryMs = Math.min(retryMs * 2, 15000);
    };
  }
  function onText(text) {
    let msg;
    try { msg = JSON.parse(text); } catch (e) { return; }
    if (msg.type === 'hello') onHello(msg);
    else if (msg.type === 'error') {
      errors.push(msg);
      if (msg.fatal && msg.code === 'busy') {
        overlay('server busy (too many clients); retrying…');  // the close that follows retries
      } else if (msg.fatal) {
        fatalError = msg.message || msg.code || 'error';
        overlay(`server: ${fatalError}`);
      } else {
        // a frame failed: its view (the last one sent: one is in flight) is answered, the next one may go
        answered = seq;
        for (const w of waiters.splice(0)) {
          clearTimeout(w.timer);
          w.reject(new Error(`the server could not render the view: ${msg.message || msg.code}`));
        }
        overlay(`frame failed: ${msg.message || msg.code}`);
        setTimeout(() => overlay(''), 3000);
      }
    }
  }
  function onHello(msg) {
    hello = msg;
    api.hello = msg;
    retryMs = 1000;
    const first = msg.scenes && msg.scenes[0];
    sceneRadius = first && first.radius > 0 ? first.radius : 1;
    // presets
    const presetSel = $('preset');
    presetSel.innerHTML = '';
    for (const p of msg.presets || ['fastest']) presetSel.add(new Option(p, p));
    if (!(msg.presets || []).includes(opts.preset)) opts.preset = msg.preset || (msg.presets || ['fastest'])[0];
    presetSel.value = opts.preset;
    // cameras
    const list = $('camera-list');
    list.innerHTML = '';
    list.add(new Option(msg.cameras && msg.cameras.length ? '(jump to camera…)' : '(no cameras)', ''));
    (msg.cameras || []).forEach((c, i) => list.add(new Option(`${c.id ?? i}: ${c.img_name ?? ''}`, String(i))));
    // compare
    $('compare-box').hidden = !msg.compare;
    if (!msg.compare) opts.compare = 'off';
    if (msg.scenes && msg.scenes.length > 1) {
      $('label-a').textContent = `A: ${msg.scenes[0].path_basename || msg.scenes[0].name}`;
      $('label-b').textContent = `B: ${msg.scenes[1].path_basename || msg.scenes[1].name}`;
    }
    // the info line
    const sc = (msg.scenes || []).map((s) =>
      `${esc(s.path_basename || s.name)}: ${fmtCount(s.gaussians)} Gaussians, SH ${s.sh_degree}${s.lod ? ', LOD' : ''}`);
    $('scene-info').innerHTML = `${esc(msg.backend)} · ${esc(msg.device || '')}<br>${sc.join('<br>')}` +
      (msg.encoder ? `<br>${esc(msg.encoder)}` : '');
    // The first resolution: on the GPU the window's device pixels (devicePixelRatio; the server renders and encodes
    // 4K at display rate); on the CPU backend, which is slow, a pixel count near the server's default size.
    if (!api._scaleChosen && msg.default_width && msg.default_height) {
      const [w, h] = frameSize(1);
      const want = msg.default_width * msg.default_height * 2;
      opts.scale = msg.backend !== 'cpu' || w * h <= want ? 1 : w * h / 4 <= want ? 0.5 : 0.25;
      $('scale').value = String(opts.scale);
    }
    // the starting view: the first scene camera, else the server's home camera, else an orbit view
    if (!api._started) {
      api._started = true;
      if (msg.compare && opts.compare === 'off') opts.compare = 'split';  // two scenes open side by side
      if (msg.cameras && msg.cameras.length && validInria(msg.cameras[0])) {
        worldUp = mul(columnOf(msg.cameras[0].rotation, 1), -1);
        poseFromInria(msg.cameras[0]);
      } else if (validInria(msg.home_camera)) {
        poseFromInria(msg.home_camera);
      } else {
        homeOrbit();
      }
    }
    $('server-mbps').textContent = msg.max_mbps > 0 ? `server ${msg.max_mbps}` : '';
    syncControls();
    answered = seq;  // views sent on an earlier connection will not be answered
    connected = true;
    api.connected = true;
    setConn('on', 'connected');
    overlay(frameCount ? '' : 'waiting for the first frame…');
    lastSentKey = '';
  }
  const columnOf = (rows, j) => [rows[0][j], rows[1][j], rows[2][j]];
  // rgs-render's first orbit view: azimuth 0 (on the −z side looking along +z), 20° above, the bounding
  // sphere filling the narrower field of view.
  function homeOrbit() {
    const s = hello && hello.scenes && hello.scenes[0];
    const centre = s && isVec3(s.center) ? s.center : [0, 0, 0];
    const [w, h] = frameSize(1);
    const fovMin = Math.min(rad(cam.fovY), 2 * Math.atan(Math.tan(rad(cam.fovY) / 2) * w / h));
    const dist = sceneRadius / Math.sin(fovMin / 2);
    const el = rad(20);
    cam.fwd = [0, Math.sin(el), Math.cos(el)];   // +y is down: looking down on the scene
    cam.down = [0, Math.cos(el), -Math.sin(el)];
    cam.right = cross(cam.down, cam.fwd);
    cam.pos = sub(centre, mul(cam.fwd, dist));
    cam.dist = dist;
    worldUp = [0, -1, 0];
    pinned = null;
  }

  function send(view) {
    if (!ws || ws.readyState !== WebSocket.OPEN || !connected) return -1;
    seq += 1;
    const msg = Object.assign({ type: 'view', seq }, view);
    ws.send(JSON.stringify(msg));
    sent.set(seq, { t: performance.now(), camera: view.camera });
    if (sent.size > 64) sent.delete(sent.keys().next().value);
    return seq;
  }
  // A view of `camera`; still (the default) asks for full quality whatever the bandwidth budget.
  function viewFor(camera, over) {
    return Object.assign({
      camera, preset: opts.preset, background: opts.background, encoding: opts.encoding, quality: opts.quality,
      compare: hello && hello.compare ? opts.compare : 'off', still: true,
    }, hello && hello.compare && opts.compare === 'diff' ? { diff_scale: opts.diffScale } : {},
    opts.maxMbps > 0 ? { max_mbps: opts.maxMbps } : {}, over || {});
  }
  // The view the screen should show now: reduced resolution while the camera moves.
  function wantedView(now) {
    const moving = now - lastInput < STILL_MS;
    const scale = moving ? opts.scale * Math.min(1, opts.motionScale) : opts.scale;
    return viewFor(currentCamera(pinned ? 1 : scale), { still: !moving });
  }
  function pump(now) {
    if (!connected || hold || seq - answered >= MAX_IN_FLIGHT) {
      // a view lost by the server (should not happen) must not stop the page for good
      const last = sent.get(seq);
      if (connected && !hold && last && now - last.t > FRAME_TIMEOUT_MS) answered = seq;
      return;
    }
    const view = wantedView(now);
    const key = JSON.stringify(view);
    if (key === lastSentKey) return;
    lastSentKey = key;
    const s = send(view);
    if (s > 0) noteRecorded(view.camera);
  }

  // ---- frames --------------------------------------------------------------------------------------------
  const mimeOf = (enc) => (enc === 'jpeg' ? 'image/jpeg' : 'image/webp');
  function fnv(bytes, h) {
    for (let i = 0; i < bytes.length; ++i) { h ^= bytes[i]; h = Math.imul(h, 16777619) >>> 0; }
    return h;
  }
  function onFrame(buf) {
    const arrival = performance.now();
    if (buf.byteLength < 4) return;
    const n = new DataView(buf).getUint32(0, true);
    let header;
    try { header = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n))); } catch (e) { return; }
    if (header.seq > answered) answered = header.seq;
    bytesTotal += buf.byteLength;
    received.push({ t: arrival, bytes: buf.byteLength });
    while (arrival - received[0].t > 1000) received.shift();
    if (header.seq < drawnSeq) return;  // older than what is on screen: dropped
    let off = 4 + n;
    let digest = 2166136261;
    const parts = [];
    for (const im of header.images || []) {
      const bytes = new Uint8Array(buf, off, im.bytes);
      off += im.bytes;
      digest = fnv(bytes, digest);
      parts.push({ role: im.role, blob: new Blob([bytes], { type: mimeOf(im.encoding) }) });
    }
    const s = sent.get(header.seq);
    const info = {
      seq: header.seq, width: header.width, height: header.height, refine: !!header.refine,
      preset: header.preset ?? null,
      images: (header.images || []).map((im) => ({ role: im.role, encoding: im.encoding, bytes: im.bytes })),
      stats: header.stats || {}, psnr: header.psnr ?? null, mse: header.mse ?? null,
      diff_max: header.diff_max ?? null, bytes: buf.byteLength, digest: digest.toString(16).padStart(8, '0'),
      camera: s ? s.camera : null, latency_ms: null, arrival_latency_ms: s ? arrival - s.t : null,
      quality: header.quality ?? null, scale: header.scale ?? 1, max_mbps: header.max_mbps ?? null,
      mbps: received.reduce((sum, r) => sum + r.bytes, 0) * 8 / 1e6,
    };
    decode(parts).then((bms) => {
      if (header.seq < drawnSeq) { closeAll(bms); return; }
      drawnSeq = header.seq;
      closeAll(bitmaps ? Object.values(bitmaps) : []);
      bitmaps = bms;
      info.latency_ms = s ? performance.now() - s.t : null;
      lastFrame = info;
      frameLog.push({ seq: info.seq, width: info.width, height: info.height });
      if (frameLog.length > 100) frameLog.shift();
      frameCount += 1;
      api.frameCount = frameCount;
      const t = performance.now();
      frameTimes.push(t);
      while (frameTimes.length && t - frameTimes[0] > 1000) frameTimes.shift();
      draw();
      showStats(info);
      overlay('');
      for (const w of waiters.slice()) {
        if (header.seq >= w.seq) {
          waiters.splice(waiters.indexOf(w), 1);
          clearTimeout(w.timer);
          w.resolve(info);
        }
      }
    }).catch((e) => overlay(`cannot decode frame ${header.seq}: ${e.message}`));
  }
  async function decode(parts) {
    const out = {};
    const bms = await Promise.all(parts.map((p) =>
      createImageBitmap(p.blob, { premultiplyAlpha: 'none', colorSpaceConversion: 'none' })));
    parts.forEach((p, i) => { out[p.role] = bms[i]; });
    return out;
  }
  function closeAll(list) { for (const b of list) if (b && b.close) b.close(); }

  // Draws `bms` onto a 2D context of the frame's size: split (A left of the slider, B right), the difference
  // heatmap, or A.
  function compose(ctx, bms, w, h) {
    ctx.clearRect(0, 0, w, h);
    if (bms.diff && (opts.compare === 'diff' || !bms.a)) {
      ctx.drawImage(bms.diff, 0, 0, w, h);
    } else if (bms.a && bms.b && opts.compare === 'split') {
      ctx.drawImage(bms.a, 0, 0, w, h);
      const x = Math.round(split * w);
      ctx.save();
      ctx.beginPath();
      ctx.rect(x, 0, w - x, h);
      ctx.clip();
      ctx.drawImage(bms.b, 0, 0, w, h);
      ctx.restore();
    } else {
      const first = bms.a || bms.b || bms.diff;
      if (first) ctx.drawImage(first, 0, 0, w, h);
    }
  }
  const canvas = $('view');
  const ctx2d = canvas.getContext('2d', { alpha: false });
  function draw() {
    if (!bitmaps || !lastFrame) return;
    const w = lastFrame.width, h = lastFrame.height;
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    compose(ctx2d, bitmaps, w, h);
    layout();
  }
  // The canvas fills the window keeping the frame's aspect ratio (centred); the split line follows it.
  let box = { x: 0, y: 0, w: 1, h: 1 };
  function layout() {
    const W = window.innerWidth, H = window.innerHeight;
    const fw = canvas.width || W, fh = canvas.height || H;
    const s = Math.min(W / fw, H / fh);
    box = { w: fw * s, h: fh * s, x: (W - fw * s) / 2, y: (H - fh * s) / 2 };
    Object.assign(canvas.style, { left: `${box.x}px`, top: `${box.y}px`, width: `${box.w}px`, height: `${box.h}px` });
    const showSplit = !!(hello && hello.compare && opts.compare === 'split');
    $('split').hidden = !showSplit;
    if (showSplit) {
      const x = box.x + split * box.w;
      Object.assign($('split-line').style, { left: `${x}px`, top: `${box.y}px`, height: `${box.h}px`, bottom: 'auto' });
      Object.assign($('split-handle').style, { left: `${x}px`, top: `${box.y + box.h / 2}px` });
      Object.assign($('label-a').style, { left: `${box.x + 10}px`, right: 'auto', top: `${box.y + 10}px` });
      // scene B's label at the right edge of the view, or left of the panel where the panel covers it
      const panel = $('panel').getBoundingClientRect();
      const rightEdge = Math.min(box.x + box.w, panel.top < box.y + 40 ? panel.left : Infinity);
      Object.assign($('label-b').style, { left: 'auto', right: `${window.innerWidth - rightEdge + 10}px`,
        top: `${box.y + 10}px` });
    }
  }

  // ---- statistics ----------------------------------------------------------------------------------------
  const fmtMs = (v) => (v === null || v === undefined ? '–' : `${Number(v).toFixed(2)} ms`);
  const fmtCount = (v) => (v === null || v === undefined ? '–' : Number(v).toLocaleString('en-US'));
  function fmtBytes(v) {
    if (v === null || v === undefined) return '–';
    const u = ['B', 'KiB', 'MiB', 'GiB', 'TiB'];
    let i = 0;
    while (v >= 1024 && i < u.length - 1) { v /= 1024; ++i; }
    return `${v.toFixed(i ? 1 : 0)} ${u[i]}`;
  }
  function esc(s) {
    return String(s ?? '').replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
  }
  function showStats(f) {
    const st = f.stats || {};
    const fps = frameTimes.length >= 2
      ? (frameTimes.length - 1) * 1000 / (frameTimes[frameTimes.length - 1] - frameTimes[0]) : null;
    const mem = st.gpu_memory_used_bytes != null
      ? `${fmtBytes(st.gpu_memory_used_bytes)} / ${fmtBytes(st.gpu_memory_total_bytes)}` : '–';
    const gpu = st.total_gpu_ms !== null && st.total_gpu_ms !== undefined;
    const lod = !!(hello && hello.scenes && hello.scenes.some((sc) => sc.lod));
    // rows the backend has no value for (the GPU stage times and memory on the CPU) are left out
    const rows = [
      ['frame', `${f.width} × ${f.height}${f.refine ? ' (refine)' : ''}`],
      gpu && ['preprocess', fmtMs(st.preprocess_ms)],
      gpu && ['sort', fmtMs(st.sort_ms)],
      gpu && ['render', fmtMs(st.render_ms)],
      gpu && ['total GPU', fmtMs(st.total_gpu_ms)],
      ['render call', fmtMs(st.render_call_ms)],
      st.readback_ms != null && ['readback', fmtMs(st.readback_ms)],
      ['encode', fmtMs(st.encode_ms)],
      ['splats', fmtCount(st.splats)],
      ['pairs', fmtCount(st.pairs)],
      st.gpu_memory_used_bytes != null && ['GPU memory', mem],
      lod && ['LOD streamed', fmtBytes(st.lod_bytes_streamed)],
      lod && ['LOD resident', fmtBytes(st.lod_bytes_resident)],
      ['frame bytes', `${fmtBytes(f.bytes)} (${f.images.map((i) => i.encoding).join('+')})`],
      ['received', fmtBytes(bytesTotal)],
      ['Mbit/s', `${f.mbps.toFixed(1)}${f.max_mbps ? ` (budget ${f.max_mbps})` : ''}`],
      ['quality', `${f.quality ?? 'lossless'}${f.scale < 1 ? ` at ${Math.round(f.scale * 100)}% size` : ''}`],
      ['frames/s', fps === null ? '–' : fps.toFixed(1)],
      ['latency', f.latency_ms === null ? '–' : `${f.latency_ms.toFixed(0)} ms`],
    ].filter(Boolean);
    $('stats').tBodies[0].innerHTML = rows.map(([k, v]) => `<tr><td>${k}</td><td>${esc(v)}</td></tr>`).join('');
    if (hello && hello.compare) {
      $('psnr').textContent = f.psnr === null ? (f.mse === 0 ? '∞ (identical)' : '–') : `${f.psnr.toFixed(2)} dB`;
      $('diff-max').textContent = f.diff_max === null ? '' : `max |Δ| ${f.diff_max}`;
    }
  }

  // ---- status line ---------------------------------------------------------------------------------------
  function setConn(cls, text) {
    const el = $('conn');
    el.className = `conn ${cls}`;
    el.textContent = text;
  }
  function overlay(text) { $('status-overlay').textContent = text; }

  // ---- input ---------------------------------------------------------------------------------------------
  function touched() {
    lastInput = performance.now();
    if (pinned) pinned = null;
    replaying = false;
  }
  const target = () => add(cam.pos, mul(cam.fwd, cam.dist));
  // Turns the camera by yaw about worldUp and pitch about its right axis, around `pivot` (orbit: the target;
  // fly: its own centre). The pitch stops short of looking straight along up or down.
  function turn(yaw, pitch, pivot) {
    let rel = sub(cam.pos, pivot);
    const r0 = cam.right, d0 = cam.down, f0 = cam.fwd;
    const r1 = rotate(r0, worldUp, yaw), d1 = rotate(d0, worldUp, yaw), f1 = rotate(f0, worldUp, yaw);
    rel = rotate(rel, worldUp, yaw);
    const f2 = rotate(f1, r1, pitch);
    if (Math.abs(dot(f2, worldUp)) < 0.995) {
      cam.fwd = f2;
      cam.down = rotate(d1, r1, pitch);
      rel = rotate(rel, r1, pitch);
    } else {
      cam.fwd = f1;
      cam.down = d1;
    }
    cam.right = r1;
    orthonormalize();
    cam.pos = add(pivot, rel);
  }
  function orbit(dx, dy) {
    turn(-dx * 0.006, -dy * 0.006, target());
  }
  function look(dx, dy) {
    turn(-dx * 0.003, -dy * 0.003, cam.pos);
  }
  // Moves the camera (and its target) so the scene follows the pointer.
  function pan(dx, dy) {
    const perPixel = 2 * cam.dist * Math.tan(rad(cam.fovY) / 2) / Math.max(1, box.h);
    cam.pos = sub(cam.pos, add(mul(cam.right, dx * perPixel), mul(cam.down, dy * perPixel)));
  }
  function dolly(factor) {
    const t = target();
    cam.dist = Math.min(Math.max(cam.dist * factor, sceneRadius * 1e-3), sceneRadius * 1e3);
    cam.pos = sub(t, mul(cam.fwd, cam.dist));
  }

  const stage = $('stage');
  const pointers = new Map();   // pointerId → {x, y}
  let dragKind = null;          // 'orbit' | 'pan' | 'look' | 'touch'
  let pinch = null;             // {d, mx, my}
  stage.addEventListener('contextmenu', (e) => e.preventDefault());
  stage.addEventListener('pointerdown', (e) => {
    stage.focus();
    stage.setPointerCapture(e.pointerId);
    pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
    if (e.pointerType === 'touch') {
      dragKind = 'touch';
      pinch = pointers.size === 2 ? pinchOf() : null;
    } else if (e.button === 2 || e.button === 1 || e.shiftKey) {
      dragKind = 'pan';
    } else {
      dragKind = opts.mode === 'fly' ? 'look' : 'orbit';
    }
    stage.classList.add('dragging');
    e.preventDefault();
  });
  function pinchOf() {
    const [a, b] = [...pointers.values()];
    return { d: Math.hypot(a.x - b.x, a.y - b.y), mx: (a.x + b.x) / 2, my: (a.y + b.y) / 2 };
  }
  stage.addEventListener('pointermove', (e) => {
    const p = pointers.get(e.pointerId);
    if (!p) return;
    const dx = e.clientX - p.x, dy = e.clientY - p.y;
    p.x = e.clientX; p.y = e.clientY;
    if (dx === 0 && dy === 0) return;
    touched();
    if (dragKind === 'touch') {
      if (pointers.size === 1) (opts.mode === 'fly' ? look : orbit)(dx, dy);
      else if (pointers.size === 2) {
        const now = pinchOf();
        if (pinch && now.d > 0) {
          dolly(pinch.d / now.d);
          pan(now.mx - pinch.mx, now.my - pinch.my);
        }
        pinch = now;
      }
    } else if (dragKind === 'pan') pan(dx, dy);
    else if (dragKind === 'look') look(dx, dy);
    else if (dragKind === 'orbit') orbit(dx, dy);
  });
  const endPointer = (e) => {
    pointers.delete(e.pointerId);
    pinch = pointers.size === 2 ? pinchOf() : null;
    if (!pointers.size) { dragKind = null; stage.classList.remove('dragging'); }
  };
  stage.addEventListener('pointerup', endPointer);
  stage.addEventListener('pointercancel', endPointer);
  stage.addEventListener('wheel', (e) => {
    e.preventDefault();
    touched();
    const dy = e.deltaMode === 1 ? e.deltaY * 33 : e.deltaMode === 2 ? e.deltaY * 400 : e.deltaY;
    if (opts.mode === 'fly') {
      cam.pos = add(cam.pos, mul(cam.fwd, -dy * sceneRadius * 0.002));
    } else {
      dolly(Math.exp(dy * 0.0015));
    }
  }, { passive: false });

  const keys = new Set();
  const MOVE_KEYS = new Set(['KeyW', 'KeyA', 'KeyS', 'KeyD', 'KeyQ', 'KeyE', 'ArrowUp', 'ArrowDown', 'ArrowLeft',
    'ArrowRight']);
  window.addEventListener('keydown', (e) => {
    if (e.target && /^(INPUT|SELECT|TEXTAREA)$/.test(e.target.tagName) && e.target.type !== 'range') return;
    if (e.ctrlKey || e.metaKey || e.altKey) return;  // the browser's shortcuts
    if (MOVE_KEYS.has(e.code)) { keys.add(e.code); e.preventDefault(); }
    if (e.code === 'KeyF' && !e.repeat) setMode(opts.mode === 'fly' ? 'orbit' : 'fly');
  });
  window.addEventListener('keyup', (e) => { keys.delete(e.code); });
  window.addEventListener('blur', () => keys.clear());
  let shiftHeld = false;
  window.addEventListener('keydown', (e) => { shiftHeld = e.shiftKey; });
  window.addEventListener('keyup', (e) => { shiftHeld = e.shiftKey; });
  function keyMotion(dt) {
    if (!keys.size) return;
    const v = sceneRadius * 0.6 * (shiftHeld ? 4 : 1) * dt;
    let m = [0, 0, 0];
    if (keys.has('KeyW') || keys.has('ArrowUp')) m = add(m, cam.fwd);
    if (keys.has('KeyS') || keys.has('ArrowDown')) m = sub(m, cam.fwd);
    if (keys.has('KeyD') || keys.has('ArrowRight')) m = add(m, cam.right);
    if (keys.has('KeyA') || keys.has('ArrowLeft')) m = sub(m, cam.right);
    if (keys.has('KeyE')) m = add(m, worldUp);
    if (keys.has('KeyQ')) m = sub(m, worldUp);
    if (norm(m) > 0) {
      touched();
      cam.pos = add(cam.pos, mul(normalize(m), v));
    }
  }

  // ---- the panel -----------------------------------------------------------------------------------------
  function setMode(mode) {
    opts.mode = mode === 'fly' ? 'fly' : 'orbit';
    $('mode-orbit').classList.toggle('on', opts.mode === 'orbit');
    $('mode-fly').classList.toggle('on', opts.mode === 'fly');
    stage.classList.toggle('fly', opts.mode === 'fly');
    $('nav-hint').textContent = opts.mode === 'fly'
      ? 'Drag: look · WASD: move · Q/E: down/up · shift: faster · wheel: forward · F: orbit'
      : 'Drag: orbit · right/shift-drag: pan · wheel: dolly · WASD/QE: move · F: fly';
  }
  function setCompare(mode) {
    opts.compare = ['off', 'split', 'diff'].includes(mode) ? mode : 'off';
    for (const m of ['off', 'split', 'diff']) $(`cmp-${m}`).classList.toggle('on', opts.compare === m);
    if (!hello || !hello.compare) return;
    if (opts.compare === 'off') { $('psnr').textContent = '–'; $('diff-max').textContent = ''; }
    layout();
  }
  function syncControls() {
    $('fov').value = String(Math.round(cam.fovY));
    $('fov-value').textContent = `${Math.round(cam.fovY)}°`;
    $('preset').value = opts.preset;
    $('scale').value = String(opts.scale);
    $('motion-scale').value = String(opts.motionScale);
    $('encoding').value = opts.encoding;
    $('quality').value = String(opts.quality);
    $('quality-value').textContent = String(opts.quality);
    $('quality').disabled = opts.encoding === 'lossless';
    $('max-mbps').value = String(opts.maxMbps);
    const hex = opts.background.map((v) => Math.round(Math.min(1, Math.max(0, v)) * 255).toString(16).padStart(2, '0'));
    $('background').value = `#${hex.join('')}`;
    setMode(opts.mode);
    setCompare(opts.compare);
    $('diff-scale').value = String(opts.diffScale);
    $('diff-scale-value').textContent = String(opts.diffScale);
  }
  $('mode-orbit').onclick = () => setMode('orbit');
  $('mode-fly').onclick = () => setMode('fly');
  $('home').onclick = () => {
    touched();
    if (hello && hello.cameras && hello.cameras.length) poseFromInria(hello.cameras[0]);
    else if (hello && validInria(hello.home_camera)) poseFromInria(hello.home_camera);
    else homeOrbit();
    syncControls();
  };
  $('camera-list').onchange = (e) => {
    const c = hello && hello.cameras ? hello.cameras[Number(e.target.value)] : null;
    if (e.target.value !== '' && validInria(c)) {
      touched();
      poseFromInria(c);
      syncControls();
    }
  };
  $('fov').oninput = (e) => {
    touched();
    cam.fovY = Number(e.target.value);
    $('fov-value').textContent = `${cam.fovY}°`;
  };
  $('preset').onchange = (e) => { opts.preset = e.target.value; };
  $('scale').onchange = (e) => { opts.scale = Number(e.target.value); api._scaleChosen = true; };
  $('motion-scale').onchange = (e) => { opts.motionScale = Number(e.target.value); };
  $('encoding').onchange = (e) => { opts.encoding = e.target.value; syncControls(); };
  $('quality').oninput = (e) => {
    opts.quality = Number(e.target.value);
    $('quality-value').textContent = e.target.value;
  };
  // The budget typed in: not a number, 0 or negative is none (0); more than the protocol's 100000 is 100000.
  const budgetOf = (v) => (Number.isFinite(Number(v)) && Number(v) > 0 ? Math.min(Number(v), 100000) : 0);
  $('max-mbps').onchange = (e) => { opts.maxMbps = budgetOf(e.target.value); syncControls(); };
  $('background').oninput = (e) => {
    const v = e.target.value;
    // the renderer writes 8-bit values without a transfer curve, so the picked value is sent as is
    opts.background = [1, 3, 5].map((i) => parseInt(v.slice(i, i + 2), 16) / 255);
  };
  for (const m of ['off', 'split', 'diff']) $(`cmp-${m}`).onclick = () => setCompare(m);
  $('diff-scale').oninput = (e) => {
    opts.diffScale = Number(e.target.value);
    $('diff-scale-value').textContent = e.target.value;
  };
  function collapsePanel(on) {
    $('panel').classList.toggle('collapsed', on);
    $('panel-toggle').textContent = on ? '+' : '–';
    layout();
  }
  $('panel-toggle').onclick = () => collapsePanel(!$('panel').classList.contains('collapsed'));
  if (window.innerWidth < 520 || window.innerHeight < 300) collapsePanel(true);  // phones: the view first

  // the split slider
  const handle = $('split-handle');
  let sliding = false;
  handle.addEventListener('pointerdown', (e) => {
    sliding = true;
    handle.setPointerCapture(e.pointerId);
    e.stopPropagation();
    e.preventDefault();
  });
  handle.addEventListener('pointermove', (e) => {
    if (!sliding) return;
    setSplit((e.clientX - box.x) / box.w);
  });
  const endSlide = () => { sliding = false; };
  handle.addEventListener('pointerup', endSlide);
  handle.addEventListener('pointercancel', endSlide);
  function setSplit(v) {
    split = Math.min(1, Math.max(0, v));
    api.split = split;
    draw();
  }

  // ---- screenshots ---------------------------------------------------------------------------------------
  function waitForFrame(s, timeoutMs) {
    if (lastFrame && lastFrame.seq >= s) return Promise.resolve(lastFrame);
    return new Promise((resolve, reject) => {
      const w = { seq: s, resolve, reject };
      w.timer = setTimeout(() => {
        waiters.splice(waiters.indexOf(w), 1);
        reject(new Error(`no frame of seq >= ${s} within ${timeoutMs} ms`));
      }, timeoutMs || FRAME_TIMEOUT_MS * 6);
      waiters.push(w);
    });
  }
  function toBase64(bytes) {
    let s = '';
    for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
    return btoa(s);
  }
  async function requestLossless(o) {
    o = o || {};
    if (!connected) throw new Error('not connected');
    if (o.camera && !validInria(o.camera)) throw new Error('not an INRIA camera');
    const camera = o.camera ? inriaMessageCamera(o.camera) : currentCamera(1);
    hold += 1;
    try {
      const s = send(viewFor(camera, { encoding: 'lossless' }));
      if (s < 0) throw new Error('not connected');
      const info = await waitForFrame(s, o.timeoutMs || 120000);
      if (info.seq !== s) throw new Error(`frame ${info.seq} came in place of ${s}`);
      const c = document.createElement('canvas');
      c.width = info.width;
      c.height = info.height;
      const g = c.getContext('2d', { alpha: false, willReadFrequently: true });
      compose(g, bitmaps, info.width, info.height);
      if (o.blob) return { seq: s, width: info.width, height: info.height, blob: await pngBlob(c) };
      const png = c.toDataURL('image/png');
      const out = { seq: s, width: info.width, height: info.height, png };
      if (o.pixels) {
        const rgba = g.getImageData(0, 0, info.width, info.height).data;
        const rgb = new Uint8Array(info.width * info.height * 3);
        for (let i = 0, j = 0; i < rgba.length; i += 4, j += 3) {
          rgb[j] = rgba[i]; rgb[j + 1] = rgba[i + 1]; rgb[j + 2] = rgba[i + 2];
        }
        out.rgb = toBase64(rgb);
      }
      return out;
    } finally {
      hold -= 1;
      if (o.camera) lastSentKey = '';  // the screen shows another camera: the current view goes again
    }
  }
  const pngBlob = (c) => new Promise((resolve, reject) =>
    c.toBlob((b) => (b ? resolve(b) : reject(new Error('the browser could not encode the PNG'))), 'image/png'));
  const inriaMessageCamera = (c) => ({ position: c.position.slice(), rotation: c.rotation.map((r) => r.slice()),
    fx: c.fx, fy: c.fy, width: c.width, height: c.height });
  $('screenshot').onclick = async () => {
    const btn = $('screenshot');
    btn.disabled = true;
    try {
      const shot = await requestLossless({ blob: true });
      download(shot.blob, `rgs_view_${shot.width}x${shot.height}_${shot.seq}.png`);
    } catch (e) {
      overlay(`screenshot failed: ${e.message}`);
      setTimeout(() => overlay(''), 3000);
    } finally {
      btn.disabled = false;
    }
  };
  function download(blob, name) {
    const a = document.createElement('a');
    a.href = URL.createObjectURL(blob);
    a.download = name;
    document.body.appendChild(a);
    a.click();
    setTimeout(() => { URL.revokeObjectURL(a.href); a.remove(); }, 1000);
  }

  // ---- camera paths --------------------------------------------------------------------------------------
  // Recorded as INRIA cameras at full resolution (scale 1): the views sent while recording (each distinct
  // pose once) and the ones added with "+ View".
  const path = [];
  let recording = false;
  let replaying = false;
  function poseKey(c) { return JSON.stringify([c.position, c.rotation, c.fx / c.width, c.fy / c.height]); }
  function addToPath(c) {
    const full = c.width === undefined ? currentCamera(1) : c;
    const last = path[path.length - 1];
    if (last && poseKey(last) === poseKey(full)) return;
    const i = path.length;
    path.push({ id: i, img_name: `path_${String(i).padStart(4, '0')}`, width: full.width, height: full.height,
      position: full.position.slice(), rotation: full.rotation.map((r) => r.slice()), fx: full.fx, fy: full.fy });
    updatePathUi();
  }
  function noteRecorded(sentCamera) {
    if (!recording || replaying) return;
    // the full-resolution camera of the pose just sent
    const full = pinned ? inriaMessageCamera(pinned) : currentCamera(1);
    if (sentCamera && full.position.join() !== sentCamera.position.join()) return;
    addToPath(full);
  }
  function updatePathUi() {
    $('record').textContent = recording ? 'Stop' : 'Record';
    $('record').classList.toggle('active', recording);
    $('replay').disabled = recording || path.length < 1;
    $('save-path').disabled = path.length < 1;
    $('path-info').textContent = path.length
      ? `${path.length} view${path.length === 1 ? '' : 's'}${recording ? ' (recording)' : ''}`
      : recording ? 'recording: move the camera' : 'no path recorded';
  }
  const pathJson = () => JSON.stringify(path, null, 1);
  async function replay() {
    if (!path.length || !connected) return;
    replaying = true;
    $('replay').disabled = true;
    try {
      for (const c of path) {
        if (!replaying) break;
        const s = setCamera(c, { exact: true });
        if (s < 0) break;
        await waitForFrame(s, 120000);
      }
    } finally {
      replaying = false;
      updatePathUi();
    }
  }
  $('record').onclick = () => {
    recording = !recording;
    if (recording) { path.length = 0; addToPath(pinned ? inriaMessageCamera(pinned) : currentCamera(1)); }
    updatePathUi();
  };
  $('add-view').onclick = () => addToPath(pinned ? inriaMessageCamera(pinned) : currentCamera(1));
  $('replay').onclick = () => { replay().catch((e) => overlay(`replay: ${e.message}`)); };
  $('save-path').onclick = () => download(new Blob([pathJson()], { type: 'application/json' }), 'cameras.json');

  // ---- the test hook -------------------------------------------------------------------------------------
  function setCamera(c, o) {
    if (!validInria(c)) throw new Error('not an INRIA camera (position, rotation, fx, fy, width, height)');
    const exact = !!(o && o.exact);
    const keepReplay = replaying;
    poseFromInria(c);
    pinned = exact ? inriaMessageCamera(c) : null;
    replaying = keepReplay;
    syncControls();
    // sent at once, as the loop would send it once still
    const view = viewFor(currentCamera(pinned ? 1 : opts.scale));
    const s = send(view);
    if (s > 0) { lastSentKey = JSON.stringify(view); noteRecorded(view.camera); }
    return s;
  }
  function setOptions(o) {
    o = o || {};
    if (o.preset !== undefined) opts.preset = o.preset;
    if (o.encoding !== undefined) opts.encoding = o.encoding;
    if (o.quality !== undefined) opts.quality = o.quality;
    if (o.background !== undefined) opts.background = o.background.slice();
    if (o.compare !== undefined) opts.compare = o.compare;
    if (o.diffScale !== undefined) opts.diffScale = o.diffScale;
    if (o.scale !== undefined) { opts.scale = o.scale; api._scaleChosen = true; }
    if (o.motionScale !== undefined) opts.motionScale = o.motionScale;
    if (o.maxMbps !== undefined) opts.maxMbps = budgetOf(o.maxMbps);
    if (o.mode !== undefined) opts.mode = o.mode;
    if (o.fovY !== undefined) { cam.fovY = o.fovY; pinned = null; }
    if (o.split !== undefined) setSplit(o.split);
    syncControls();
  }
  const api = {
    connected: false, frameCount: 0, hello: null, errors, split,
    _started: false, _scaleChosen: false,
    lastFrame: () => lastFrame,
    frameLog: () => frameLog.slice(),
    camera: () => currentCamera(pinned ? 1 : opts.scale),
    target: () => target(),
    mode: () => opts.mode,
    setCamera, setOptions, waitForFrame, requestLossless,
    record: {
      start() { recording = true; path.length = 0; updatePathUi(); },
      stop() { recording = false; updatePathUi(); },
      add() { addToPath(pinned ? inriaMessageCamera(pinned) : currentCamera(1)); },
      clear() { path.length = 0; updatePathUi(); },
      cameras: () => JSON.parse(pathJson()),
      json: pathJson,
      replay,
      get recording() { return recording; },
    },
  };
  window.rgsView = api;

  // ---- the loop ------------------------------------------------------------------------------------------
  let lastTick = performance.now();
  function tick(now) {
    const dt = Math.min(0.1, (now - lastTick) / 1000);
    lastTick = now;
    keyMotion(dt);
    pump(now);
    requestAnimationFrame(tick);
  }
  window.addEventListener('resize', () => { layout(); lastInput = performance.now(); });
  syncControls();
  updatePathUi();
  layout();
  connect();
  requestAnimationFrame(tick);
})();

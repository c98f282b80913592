// surfhap live touch page: Pointer Events -> WebSocket -> engine; trace and counters back.
// No build step, no dependencies. window.surfhap exposes counters for tests.
"use strict";
(function () {
  const surface = document.getElementById("surface");
  const trace = document.getElementById("trace");
  const $ = (id) => document.getElementById(id);
  const recent = [];  // counters of the last few status messages (about 1 s): shares over them
  // A share (saturation, missed ticks) is green below its warning level, amber from it, red from
  // its bad level. Saturation: 0.1 % is the demo's fidelity target (docs/texture.md), and above
  // 1 % the friction no longer follows the model. Missed ticks (haptic loop) or underruns (drive
  // blocks): 1 % and 5 %, the page's choice (docs/live.md).
  const LEVELS = { saturation: [0.001, 0.01], missed: [0.01, 0.05] };
  const stats = { sent: 0, acked: -1, traceFrames: 0, tracePointsDrawn: 0, lastRtt: null, maxV: 0, open: false };
  window.surfhap = stats;
  const pct = (x) => `${(100 * x).toFixed(x < 0.1 ? 2 : 1)} %`;
  // the class of a share ``frac`` against LEVELS[kind]: "ok", "warn" or "bad"
  stats.level = (frac, kind) => (frac >= LEVELS[kind][1] ? "bad" : frac >= LEVELS[kind][0] ? "warn" : "ok");
  function showShare(id, text, frac, kind) {
    const el = $(id); el.textContent = text; el.className = stats.level(frac, kind); el.dataset.share = String(frac);
  }
  // the share of ``part`` in ``whole`` over the recent status messages (counters read by ``get``)
  function recentShare(get) {
    if (recent.length < 2) return null;
    const [p0, w0] = get(recent[0]), [p1, w1] = get(recent[recent.length - 1]);
    return w1 > w0 ? (p1 - p0) / (w1 - w0) : null;
  }
  function remember(s) { recent.push(s); if (recent.length > 6) recent.shift(); }
  const sentAt = new Map(); // seq -> performance.now() at send (bounded below)
  let seq = 0, ws = null, info = null, preview = null;
  const hist = { t: [], v: [], f: [] };
  const HIST_S = 3.0;

  function fit(c) {
    const r = c.getBoundingClientRect(), d = window.devicePixelRatio || 1;
    c.width = Math.max(1, Math.round(r.width * d)); c.height = Math.max(1, Math.round(r.height * d));
  }

  function drawSurface() {
    fit(surface);
    const g = surface.getContext("2d");
    g.fillStyle = "#444"; g.fillRect(0, 0, surface.width, surface.height);
    if (preview) g.drawImage(preview, 0, 0, surface.width, surface.height);
    g.fillStyle = "rgba(0,0,0,0.45)"; g.fillRect(0, 0, surface.width, 26 * (window.devicePixelRatio || 1));
    g.fillStyle = "#fff"; g.font = `${14 * (window.devicePixelRatio || 1)}px system-ui`;
    g.fillText(info ? info.title + " — drag here" : "loading…", 8, 18 * (window.devicePixelRatio || 1));
  }

  function makePreview(p) {
    const c = document.createElement("canvas"); c.width = p.w; c.height = p.h;
    const g = c.getContext("2d"), img = g.createImageData(p.w, p.h);
    for (let i = 0; i < p.w * p.h; i++) {
      const v = p.data[i];
      img.data[4 * i] = Math.min(255, v * 1.05 + 20); img.data[4 * i + 1] = v * 0.9 + 10;
      img.data[4 * i + 2] = v * 0.7; img.data[4 * i + 3] = 255;
    }
    g.putImageData(img, 0, 0); return c;
  }

  function send(obj) {
    if (ws && ws.readyState === 1) { ws.send(JSON.stringify(obj)); return true; }
    return false;
  }
  function hello() {
    const r = surface.getBoundingClientRect();
    send({ type: "hello", w: Math.max(10, r.width), h: Math.max(10, r.height) });
  }

  // One move per animation frame: pointer events can come faster than the display (pens,
  // 240 Hz digitisers, browsers that do not align them to frames); only the newest position
  // of a frame is sent (stats.coalesced counts the others). While a finger rests, browsers
  // send no pointermove; the engine's watchdog would then fade the output after 50 ms. A
  // resting contact is re-sent every 20 ms (keep-alive).
  let down = null, lastSend = 0, pending = null, frameAsked = false;
  stats.coalesced = 0;
  function sendMove(t, x, y, p) {
    pending = null;
    const s = seq++;
    if (send({ type: "move", seq: s, t: t, x: x, y: y, p: p })) {
      stats.sent++; lastSend = performance.now(); sentAt.set(s, lastSend);
      if (sentAt.size > 512) sentAt.delete(sentAt.keys().next().value);
    }
  }
  function flushMove() {
    if (pending) sendMove(pending.t, pending.x, pending.y, pending.p);
  }
  function onMove(e) {
    if (e.type === "pointermove" && e.buttons === 0) return; // hovering mouse or pen: no contact
    const r = surface.getBoundingClientRect();
    down = { x: (e.clientX - r.left) / r.width, y: (e.clientY - r.top) / r.height, p: e.pressure > 0 ? e.pressure : 0.5 };
    if (pending) stats.coalesced++;
    pending = { t: e.timeStamp, x: down.x, y: down.y, p: down.p };
    if (!frameAsked) { frameAsked = true; requestAnimationFrame(() => { frameAsked = false; flushMove(); }); }
    e.preventDefault();
  }
  function onUp(e) {
    flushMove(); // the last position first, then the lift
    down = null;
    const s = seq++;
    if (send({ type: "up", seq: s, t: e.timeStamp })) { stats.sent++; sentAt.set(s, performance.now()); }
  }
  setInterval(() => {
    const t = performance.now();
    if (!down || t - lastSend < 20) return;
    if (pending) flushMove(); // no animation frame for 20 ms (a hidden or busy page)
    else { sendMove(t, down.x, down.y, down.p); stats.keepAlive = (stats.keepAlive || 0) + 1; }
  }, 10);
  surface.addEventListener("pointerdown", (e) => { surface.setPointerCapture(e.pointerId); onMove(e); });
  surface.addEventListener("pointermove", onMove);
  for (const ev of ["pointerup", "pointercancel"]) surface.addEventListener(ev, onUp);

  // y scales: each trace its own, labelled beside the canvas (left: drive, right: friction or
  // Fx). The drive's is fixed (0 to its full scale); the other's is the next 1, 2, 5 x 10^k above
  // the trace's peak over the last 3 s, from 0 for the friction, symmetric around 0 for the signed Fx.
  const nice = (x) => { const e = Math.pow(10, Math.floor(Math.log10(x))); return [1, 2, 5, 10].find((m) => m * e >= x * (1 - 1e-9)) * e; };
  const num = (x) => String(Number(x.toPrecision(3)));
  function label(axis, lo, hi, unit) {
    $(`axis-${axis}-top`).textContent = `${num(hi)} ${unit}`; $(`axis-${axis}-bot`).textContent = `${num(lo)} ${unit}`;
    $(`axis-${axis}-mid`).textContent = `${num((lo + hi) / 2)} ${unit}`;
    const el = $(`axis-${axis}`); el.dataset.lo = String(lo); el.dataset.hi = String(hi);
  }
  function drawTrace() {
    fit(trace);
    const g = trace.getContext("2d"), W = trace.width, H = trace.height;
    g.fillStyle = "#0d0e10"; g.fillRect(0, 0, W, H);
    g.strokeStyle = "#2a2e35"; g.beginPath();
    for (const y of [4, H / 2, H - 4]) { g.moveTo(0, y); g.lineTo(W, y); }
    g.stroke();
    const vmax = info ? info.drive_full_scale : 250, unit = info ? info.drive_unit : "V";
    let fpeak = 0; for (const f of hist.f) fpeak = Math.max(fpeak, Math.abs(f));
    const ftop = nice(Math.max(fpeak, ff ? 0.01 : 0.001)), flo = ff ? -ftop : 0;
    label("v", 0, vmax, unit); label("f", flo, ftop, "N");
    const n = hist.t.length; if (n < 2) return;
    const t1 = hist.t[n - 1], t0 = t1 - HIST_S;
    const line = (arr, lo, hi, color) => {
      g.strokeStyle = color; g.lineWidth = 1.5 * (window.devicePixelRatio || 1); g.beginPath();
      for (let i = 0; i < n; i++) {
        const x = ((hist.t[i] - t0) / HIST_S) * W, y = H - 4 - ((arr[i] - lo) / (hi - lo)) * (H - 8);
        if (i === 0) g.moveTo(x, y); else g.lineTo(x, y);
      }
      g.stroke();
    };
    line(hist.v, 0, vmax, "#f0c040"); line(hist.f, flo, ftop, "#60b0f0");
    stats.tracePointsDrawn += n;
  }

  // ---- force-feedback panel (surfhap ff run SCENE --touch web) ----------------------------
  // info.ff: device workspace half-sizes (m) and force limits (N) per axis, effect names by
  // mask bit, button names; each trace frame's m.ff: p (n, 3) m, F (n, 3) N, mask, button.
  const ffview = $("ffview");
  let ff = null;
  function ffSetup(desc) {
    ff = desc;
    stats.ff = { frames: 0, p: null, F: null, mask: 0, button: -1, presses: 0 };
    $("ffpanel").hidden = false;
    $("leg-v").textContent = "■ |F| sent to the device (left scale)";
    $("leg-f").textContent = "■ Fx sent (right scale, 0 in the middle)";
    const head = (id, text, title) => { $(id).textContent = text; $(id).title = title; };
    head("lat-h", "tick error", "haptic tick period error, p50 / p99");
    head("blocks-h", "ticks", "haptic ticks run");
    head("runs-h", "missed ticks", "share of the haptic ticks missed over the last ~1 s");
    head("rej-h", "rejected / dropped", "touch messages rejected / touches dropped");
    head("safety-h", "clamp / slew / lost / wall", "safety: force clamped / slew limited / device lost / workspace wall");
    // not v_max: the force the device was asked for beyond its limit, in N
    const lim = [...new Set(desc.f_max_n)].map(num).join(" / ");
    head("sat-h", `force clamped at ±${lim} N`, "share of the haptic ticks whose force was clamped to the device's limit (x / y / z) over the last ~1 s");
    const bt = $("ff-button"); bt.textContent = desc.buttons.length ? "" : "no buttons in this scene";
    desc.buttons.forEach((name, i) => {
      const b = document.createElement("span"); b.className = "btn"; b.textContent = name; b.dataset.index = String(i);
      b.setAttribute("role", "switch"); b.setAttribute("aria-checked", "false"); bt.appendChild(b);
    });
    ffDraw();
  }
  const mm = (v) => (1e3 * v).toFixed(2);
  function ffStatus(s) {
    const pe = s.period_error_ms || {}, sf = s.safety || {};
    $("lat").textContent = `${(pe.p50 || 0).toFixed(3)} / ${(pe.p99 || 0).toFixed(3)} ms`;
    $("blocks").textContent = String(s.ticks);
    stats.touchesDropped = s.touches_dropped;
    $("safety").textContent = `${sf.clamped} / ${sf.slew_limited} / ${sf.device_lost} / ${sf.workspace}`;
    remember(s);
    const miss = recentShare((r) => [r.missed, r.ticks + r.missed]);
    if (miss !== null) showShare("runs", `${pct(miss)} of ticks`, miss, "missed");
    const sat = recentShare((r) => [r.safety.clamped, r.ticks]);
    if (sat !== null) showShare("sat", `${pct(sat)} of ticks`, sat, "saturation");
    $("output").textContent = s.error ? `FAILED: ${s.error}` : (s.output ? s.output.name : "–");
  }
  function onFF(d) {
    const n = d.p.length; if (!n || !ff) return;
    const p = d.p[n - 1], F = d.F[n - 1], mask = d.mask[n - 1], b = d.button[n - 1], st = stats.ff;
    for (let i = 0; i < n; i++) if (d.button[i] >= 0 && (i ? d.button[i - 1] : st.button) !== d.button[i]) st.presses++;
    Object.assign(st, { p: p, F: F, mask: mask, button: b }); st.frames++;
    const pos = $("ff-pos"), flat = $("ff-flat"), fz = $("ff-fz"), fabs = $("ff-fabs");
    pos.textContent = `${mm(p[0])}, ${mm(p[1])}, ${mm(p[2])} mm`; pos.dataset.m = JSON.stringify(p);
    flat.textContent = `${F[0].toFixed(3)}, ${F[1].toFixed(3)} N`; flat.dataset.n = JSON.stringify([F[0], F[1]]);
    fz.textContent = `${F[2].toFixed(3)} N`; fz.dataset.n = String(F[2]);
    fabs.textContent = `${Math.hypot(F[0], F[1], F[2]).toFixed(3)} N`;
    const names = ff.effects.filter((_, i) => (mask >> i) & 1);
    $("ff-effects").textContent = names.length ? names.join(", ") : "idle"; $("ff-effects").dataset.mask = String(mask);
    const bt = $("ff-button");
    for (const el of bt.children) {
      const on = Number(el.dataset.index) === b;
      el.classList.toggle("pressed", on); el.setAttribute("aria-checked", String(on));
    }
    bt.dataset.index = String(b); bt.dataset.presses = String(st.presses);
    ffDraw();
  }
  function ffDraw() {
    if (!ff) return;
    fit(ffview);
    const g = ffview.getContext("2d"), W = ffview.width, H = ffview.height, d = window.devicePixelRatio || 1;
    const st = stats.ff, p = st.p || [0, 0, 0], F = st.F || [0, 0, 0];
    const [wx, wy, wz] = ff.workspace_m, [fxm, fym, fzm] = ff.f_max_n;
    g.fillStyle = "#0d0e10"; g.fillRect(0, 0, W, H);
    g.font = `${10 * d}px system-ui`; g.lineWidth = 1.5 * d;
    // top view: the workspace box (x right, y down as on the screen), the device and F lateral
    const m = 14 * d, side = H - 2 * m, sx = side / (2 * wx), sy = side / (2 * wy), cx = m + side / 2, cy = m + side / 2;
    g.strokeStyle = "#3a3f47"; g.strokeRect(m, m, side, side);
    g.beginPath(); g.moveTo(cx, m); g.lineTo(cx, m + side); g.moveTo(m, cy); g.lineTo(m + side, cy); g.stroke();
    const dx = cx + Math.max(-wx, Math.min(wx, p[0])) * sx, dy = cy + Math.max(-wy, Math.min(wy, p[1])) * sy;
    g.fillStyle = "#f0c040"; g.beginPath(); g.arc(dx, dy, 4 * d, 0, 2 * Math.PI); g.fill();
    const ax = dx + (F[0] / fxm) * side / 2, ay = dy + (F[1] / fym) * side / 2;
    g.strokeStyle = "#60b0f0"; g.beginPath(); g.moveTo(dx, dy); g.lineTo(ax, ay); g.stroke();
    const ang = Math.atan2(ay - dy, ax - dx), hl = 6 * d;
    if (Math.hypot(ax - dx, ay - dy) > 2 * d) {
      g.beginPath(); g.moveTo(ax, ay); g.lineTo(ax - hl * Math.cos(ang - 0.4), ay - hl * Math.sin(ang - 0.4));
      g.lineTo(ax - hl * Math.cos(ang + 0.4), ay - hl * Math.sin(ang + 0.4)); g.closePath(); g.fillStyle = "#60b0f0"; g.fill();
    }
    g.fillStyle = "#9aa0a8";
    g.fillText(`top view ±${mm(wx)} × ±${mm(wy)} mm, arrow: F lateral (±${fxm} N)`, m, m - 3 * d);
    // z bar (device height, up = towards the user) and Fz bar (normal force)
    const bar = (x, v, vmax, color, label) => {
      const h = side, y0 = m + h / 2, v1 = Math.max(-vmax, Math.min(vmax, v));
      g.strokeStyle = "#3a3f47"; g.strokeRect(x, m, 14 * d, h);
      g.fillStyle = color; const hh = -(v1 / vmax) * h / 2;
      g.fillRect(x, Math.min(y0, y0 + hh), 14 * d, Math.max(1, Math.abs(hh)));
      g.fillStyle = "#9aa0a8"; g.fillText(label, x - 2 * d, m + h + 11 * d);
    };
    const bx = m + side + 18 * d;
    bar(bx, p[2], wz, "#f0c040", "z"); bar(bx + 34 * d, F[2], fzm, "#60b0f0", "Fz");
    g.fillStyle = "#9aa0a8";
    g.fillText(`z ±${mm(wz)} mm`, bx + 70 * d, m + 10 * d); g.fillText(`Fz ±${fzm} N`, bx + 70 * d, m + 24 * d);
  }

  const ms = (s) => (s == null ? "–" : (1e3 * s).toFixed(2) + " ms");
  function onTrace(m) {
    stats.traceFrames++;
    for (let i = 0; i < m.t.length; i++) {
      hist.t.push(m.t[i]); hist.v.push(m.v[i]); hist.f.push(m.f[i]);
      if (m.v[i] > stats.maxV) stats.maxV = m.v[i];
    }
    const tEnd = hist.t.length ? hist.t[hist.t.length - 1] : 0;
    while (hist.t.length && hist.t[0] < tEnd - HIST_S) { hist.t.shift(); hist.v.shift(); hist.f.shift(); }
    if (m.ack > stats.acked) {
      stats.acked = m.ack;
      const t = sentAt.get(m.ack);
      if (t !== undefined) stats.lastRtt = (performance.now() - t) / 1e3;
    }
    $("sent").textContent = `${stats.sent} / ${m.received}`;
    $("rej").textContent = ff ? `${m.rejected} / ${stats.touchesDropped || 0}` : String(m.rejected);
    $("rtt").textContent = ms(stats.lastRtt);
    if (m.ff) onFF(m.ff);
    if (m.status && m.status.period_error_ms) ffStatus(m.status);
    else if (m.status) {
      const s = m.status, c = s.counters, sf = s.safety;
      $("lat").textContent = s.latency.p50 == null ? "–" : `${(1e3 * s.latency.p50).toFixed(2)} / ${ms(s.latency.p99)}`;
      $("blocks").textContent = `${c.blocks} × ${(s.block_period * 1e3).toFixed(2)} ms`; $("blocks").title = "blocks rendered × block period";
      $("safety").textContent = `${sf.clamped} / ${sf.watchdog} / ${sf.faults}`;
      remember(s);  // the shares over the last ~1 s: blocks underrun, drive samples clamped to v_max
      const under = recentShare((r) => [r.counters.underruns, r.counters.blocks + r.counters.underruns]);
      if (under !== null) showShare("runs", `${c.underruns} / ${c.overruns} · ${pct(under)}`, under, "missed");
      const frac = recentShare((r) => [r.safety.clamped, r.safety.samples]);
      if (frac !== null) showShare("sat", frac > 0.01 ? `${pct(frac)} SATURATED` : pct(frac), frac, "saturation");
      $("output").textContent = s.failure ? `FAILED (0 V): ${s.failure}` : (s.output ? s.output.name : "–");
    }
    drawTrace();
  }

  function connect() {
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    ws = new WebSocket(`${proto}//${location.host}/ws`);
    ws.onopen = () => { stats.open = true; $("conn").textContent = "live"; $("conn").className = "ok"; hello(); };
    ws.onclose = () => {
      stats.open = false; $("conn").textContent = "disconnected – retrying"; $("conn").className = "bad";
      setTimeout(connect, 1000);
    };
    ws.onmessage = (ev) => {
      let m; try { m = JSON.parse(ev.data); } catch (_) { return; }
      if (m && m.type === "trace") onTrace(m);
    };
  }

  fetch("/api/info").then((r) => r.json()).then((j) => {
    info = j; $("title").textContent = `surfhap live — ${j.title}`;
    if (j.ff) ffSetup(j.ff);
    preview = makePreview(j.preview); drawSurface();
  });
  window.addEventListener("resize", () => { drawSurface(); ffDraw(); hello(); });
  drawSurface();
  connect();
})();

// surfhap study page: shows the current trial, sends answers with response times.
"use strict";
(function () {
  const $ = (id) => document.getElementById(id);
  const S = (window.study = { trialId: null, answered: 0, status: "loading", selected: null, staleDropped: 0,
                               played: [], blank: false });
  let shownAt = 0, busy = false, toggleValues = {}, ws = null, seq = 0;
  // the trial shown; the stimuli still to play before an answer (each must be touched, or
  // clicked for a real sample); the running stimulus clock (a time-limited stimulus)
  let T = null, need = new Set(), clock = null;

  function show(id) {
    for (const s of ["loading", "info", "trial", "rest", "done", "paused", "feedback"]) $(s).hidden = s !== id;
    S.status = id;
  }
  function error(msg) { $("error").textContent = msg; $("error").hidden = !msg; }

  async function call(method, url, body) {
    const r = await fetch(url, { method, headers: { "Content-Type": "application/json" },
                                 body: body === undefined ? undefined : JSON.stringify(body) });
    const data = await r.json();
    if (!r.ok) throw new Error(data.error || r.statusText);
    return data;
  }

  // Responses can arrive out of order (a poll sent just before an answer may land after the
  // answer's response): a state older than the newest one shown would re-show an answered trial
  // and restart its response-time clock. A response to a request older than the newest one
  // rendered so far is marked stale, and render() ignores it.
  let issued = 0, newestRendered = 0;
  async function state(method, url, body) {
    const n = ++issued;
    const st = await call(method, url, body);
    st.stale = n < newestRendered;
    if (st.stale) S.staleDropped += 1; else newestRendered = n;
    return st;
  }

  function render(st) {
    if (st.stale || (S.status === "feedback" && st.status !== "paused")) return;  // feedback: until Next
    $("progress").textContent = st.total ? `${st.done} / ${st.total}` : "";
    // never the block's label: it names the condition, which the participant must not know
    $("block").textContent = st.blocks > 1 && st.block_number ? `block ${st.block_number} of ${st.blocks}` : "";
    if (st.status === "done") {  // next_session: this session is over, the study is not
      $("done-text").textContent = st.next_session ? "Thank you! This session is done; please come back another day."
        : "Thank you! The session is complete.";
      show("done"); S.trialId = null; return;
    }
    if (st.status === "paused") {  // the experimenter paused the session: a neutral screen, the output is off
      clearTimeout(clock); clock = null; blank(false);
      show("paused"); S.trialId = null; return;
    }
    if (st.status === "info") {  // the participant-information form, before the first trial
      if (S.status !== "info") form(st.info);
      show("info"); S.trialId = null; return;
    }
    if (st.status === "rest") {
      $("next-block").textContent = st.block_number ? `Next: block ${st.block_number} of ${st.blocks}` : "";
      show("rest"); S.trialId = null; return;
    }
    const t = st.trial;
    if (t.id === S.trialId && S.status === "trial") return;  // already shown
    S.trialId = t.id; S.selected = null; S.played = []; toggleValues = {}; T = t; error("");
    clearTimeout(clock); clock = null; blank(false);
    need = new Set(t.touch === false ? [] : t.stimuli.map((_, i) => i));  // a look-only trial: nothing to play
    $("prompt").textContent = t.prompt;
    const stim = $("stimuli"); stim.replaceChildren();
    t.stimuli.forEach((label, i) => {
      const b = document.createElement("button");
      b.className = "stim"; b.textContent = t.real[i] ? `${label} (real sample)` : label;
      b.dataset.index = i;
      b.disabled = !!t.limit_s;  // timed stimuli play in their order, one after the other
      b.onclick = () => select(t.id, i);
      stim.appendChild(b);
    });
    stim.hidden = t.touch === false;
    $("stimuli-caption").hidden = stim.hidden;
    const ch = $("choices"); ch.replaceChildren();
    const tg = $("toggles"); tg.replaceChildren();
    const text = $("text"); text.value = ""; text.hidden = t.response !== "text";
    if (t.response === "text") {  // a free-text answer, sent verbatim
      ch.hidden = true; tg.hidden = true; $("submit").hidden = false;
      $("submit").onclick = () => answer(t.id, text.value);
    } else if (t.response === "toggles") {
      ch.hidden = true; tg.hidden = false; $("submit").hidden = false;
      const values = t.choices.map((c) => c.id);
      t.toggles.forEach((pos) => {
        const b = document.createElement("button");
        b.textContent = `${pos}: ?`; b.dataset.pos = pos;
        b.onclick = () => {
          const cur = values.indexOf(toggleValues[pos]);
          toggleValues[pos] = values[(cur + 1) % values.length];
          b.textContent = `${pos}: ${t.choices[values.indexOf(toggleValues[pos])].label}`;
          b.classList.add("set");
          gate();
        };
        tg.appendChild(b);
      });
      $("submit").onclick = () => answer(t.id, t.toggles.map((p) => `${p}=${toggleValues[p]}`).join(","));
    } else {
      ch.hidden = false; tg.hidden = true; $("submit").hidden = true;
      t.choices.forEach((c) => {
        const b = document.createElement("button");
        b.className = "answer"; b.textContent = c.label; b.dataset.choice = c.id;
        b.onclick = () => answer(t.id, c.id);
        ch.appendChild(b);
      });
    }
    const pad = $("pad");
    if (t.image) {  // the scene's picture; the pad spans the touch surface, so picture and shape line up
      const img = new Image();
      img.onload = () => pad.style.setProperty("--ratio", `${img.naturalWidth / img.naturalHeight}`);
      img.src = `/api/image/${encodeURIComponent(t.id)}`;
      pad.style.backgroundImage = `url("${img.src}")`;
      pad.style.setProperty("--ratio", "1.6");  // until the picture is in
      pad.classList.add("picture");
    } else {
      pad.style.backgroundImage = "";
      pad.classList.remove("picture");
    }
    pad.firstElementChild.textContent = t.touch === false ? "look only" : "touch and slide here";
    gate();
    show("trial");
    hello();
    shownAt = performance.now();
    if (t.limit_s && need.size) select(t.id, 0);
  }

  // answers stay disabled until every stimulus of the trial was played (and, for toggles,
  // every position set)
  function gate() {
    const open = [...need].every((i) => S.played.includes(i));
    S.answerable = open;
    for (const b of document.querySelectorAll("#choices button, #toggles button, #text")) b.disabled = !open;
    $("submit").disabled = !open || (T && T.response === "toggles" && Object.keys(toggleValues).length !== T.toggles.length)
      || (T && T.response === "text" && !$("text").value.trim());
  }
  function played(i) {
    if (!S.played.includes(i)) S.played.push(i);
    const b = document.querySelector(`button.stim[data-index="${i}"]`);
    if (b) b.classList.add("played");
    gate();
  }
  function blank(on) { S.blank = on; $("blank").hidden = !on; }

  // a poll clears only its own "not reachable" message, never a refused form's or answer's
  let unreachable = false;
  async function refresh() {
    try { render(await state("GET", "/api/state")); if (unreachable) { error(""); unreachable = false; } }
    catch (e) { error(`server not reachable (${e.message}); retrying`); unreachable = true; }
  }

  async function select(tid, i) {
    for (const b of document.querySelectorAll("button.stim")) {
      b.classList.toggle("active", +b.dataset.index === i);
      b.classList.toggle("played", S.played.includes(+b.dataset.index));
    }
    S.selected = i;
    if (T.real[i]) played(i);  // a real sample is handed over: the click is its play
    try { await call("POST", "/api/stimulus", { trial_id: tid, index: i }); } catch (e) { error(e.message); }
  }

  async function answer(tid, value) {
    if (busy || tid !== S.trialId) return;
    busy = true;
    const rt = performance.now() - shownAt;
    for (const b of document.querySelectorAll("#choices button, #toggles button, #submit")) b.disabled = true;
    try {
      const st = await state("POST", "/api/answer", { trial_id: tid, answer: value, rt_ms: rt });
      if (st.accepted) S.answered += 1;
      if (st.feedback) {  // a training trial: right or wrong and the right answer, then Next
        $("fb-result").textContent = st.feedback.correct ? "Correct!" : "Not quite.";
        $("fb-answer").textContent = `The right answer: ${st.feedback.answer}`;
        S.trialId = null; show("feedback");
      } else render(st);
    } catch (e) { error(e.message); await refresh(); }
    finally {
      busy = false;
      gate();
    }
  }

  function form(fields) {
    const box = $("info-fields"); box.replaceChildren();
    for (const f of fields) {
      const label = document.createElement("label"); label.textContent = f.label;
      let input;
      if (f.kind === "choice") {
        input = document.createElement("select"); input.add(new Option("", ""));
        for (const c of f.choices) input.add(new Option(c, c));
      } else {
        input = document.createElement("input"); input.type = f.kind === "number" ? "number" : "text";
        if (f.kind === "number") { input.step = "any"; if (f.min !== null) input.min = f.min; if (f.max !== null) input.max = f.max; }
        else input.maxLength = 200;
      }
      input.name = f.id; input.dataset.kind = f.kind; input.required = true;
      label.append(input); box.append(label);
    }
  }
  $("info").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const answers = {};
    for (const el of $("info-fields").querySelectorAll("[name]"))
      answers[el.name] = el.dataset.kind === "number" ? Number(el.value) : el.value;
    try { const st = await state("POST", "/api/info", { answers }); error(""); render(st); }
    catch (e) { error(e.message); }
  });

  $("text").addEventListener("input", gate);
  $("fb-next").onclick = () => { show("loading"); refresh(); };
  $("continue").onclick = async () => { render(await state("POST", "/api/resume")); };

  // touch pad -> live engine (ignored by the server when no live output is configured)
  function openSocket() {
    try {
      ws = new WebSocket(`ws://${location.host}/ws`);
      ws.onopen = () => { S.wsOpen = true; hello(); };
      ws.onclose = () => { S.wsOpen = false; ws = null; setTimeout(openSocket, 2000); };
    } catch (e) { ws = null; }
  }
  function send(msg) { if (ws && ws.readyState === 1) ws.send(JSON.stringify(msg)); }
  function hello() {  // the pad's size in px (once it is laid out)
    const r = $("pad").getBoundingClientRect();
    if (r.width >= 10 && r.height >= 10) send({ type: "hello", w: r.width, h: r.height });
  }
  // a resting finger sends no pointermove: re-send it every 20 ms so the watchdog keeps the drive on
  const pad = $("pad");
  let down = null, lastSend = 0;
  function sendMove(t, x, y, p) { send({ type: "move", seq: seq++, t: t, x: x, y: y, p: p }); lastSend = performance.now(); }
  function onMove(e) {
    if (e.type === "pointermove" && e.buttons === 0) return;  // hovering: no contact
    const r = pad.getBoundingClientRect();
    down = { x: (e.clientX - r.left) / r.width, y: (e.clientY - r.top) / r.height, p: e.pressure > 0 ? e.pressure : 0.5 };
    sendMove(e.timeStamp, down.x, down.y, down.p);
    e.preventDefault();
  }
  function onUp(e) {
    down = null; send({ type: "up", seq: seq++, t: e.timeStamp });
    if (S.blank) {  // released after a timed stimulus: the next one, or the question
      blank(false);
      const next = T.stimuli.findIndex((_, i) => need.has(i) && !S.played.includes(i));
      if (next >= 0) select(S.trialId, next);
    }
  }
  function onDown(e) {  // the selected stimulus is touched: played (a timed one once its time is over)
    const i = S.selected;
    if (i === null || S.blank || T.touch === false) return;
    if (!T.limit_s) { played(i); return; }
    if (clock === null && !S.played.includes(i)) {
      const tid = S.trialId;
      clock = setTimeout(() => {
        clock = null;
        if (S.trialId !== tid) return;
        played(i);
        if (T.blank && down) blank(true);  // black until the finger is lifted
        else { const next = T.stimuli.findIndex((_, k) => need.has(k) && !S.played.includes(k)); if (next >= 0) select(tid, next); }
      }, T.limit_s * 1000);
    }
  }
  setInterval(() => { const t = performance.now(); if (down && t - lastSend >= 20) sendMove(t, down.x, down.y, down.p); }, 10);
  pad.addEventListener("pointerdown", (e) => { pad.setPointerCapture(e.pointerId); onMove(e); onDown(e); });
  pad.addEventListener("pointermove", onMove);
  for (const ev of ["pointerup", "pointercancel"]) pad.addEventListener(ev, onUp);

  openSocket();
  refresh();
  setInterval(() => { if (!busy) refresh(); }, 1000);
})();

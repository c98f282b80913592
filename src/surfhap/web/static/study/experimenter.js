// surfhap study: the experimenter's page (pause, resume, skip, notes); the token of the URL
// goes with every API call in the X-Experimenter-Token header.
"use strict";
(function () {
  const $ = (id) => document.getElementById(id);
  const token = new URLSearchParams(location.search).get("token") || "";
  const E = (window.experimenter = { state: null, notes: 0 });

  async function call(method, path, body) {
    const r = await fetch(`/experimenter/api/${path}`, {
      method, headers: { "Content-Type": "application/json", "X-Experimenter-Token": token },
      body: body === undefined ? undefined : JSON.stringify(body) });
    const data = await r.json();
    if (!r.ok) throw new Error(data.detail || data.error || r.statusText);
    return data;
  }
  function show(st) {
    E.state = st;
    $("participant").textContent = st.participant;
    $("status").textContent = st.paused ? "paused" : st.status;
    $("block").textContent = st.blocks ? `${st.block_number} of ${st.blocks}` : "";
    $("trial").textContent = `${st.trial} of ${st.total}` + (st.practice ? " (practice)" : "");
    const s = Math.floor(st.elapsed_s);
    $("elapsed").textContent = `${Math.floor(s / 60)} min ${String(s % 60).padStart(2, "0")} s`;
    if (st.condition) $("condition").textContent = Object.entries(st.condition).map(([k, v]) => `${k}: ${v}`).join(", ");
    $("pause").disabled = st.paused || st.status === "done";
    $("resume").disabled = !st.paused;
    $("skip").disabled = !st.trial_id;
  }
  async function act(method, path, body) {
    try { show(await call(method, path, body)); $("error").hidden = true; }
    catch (e) { $("error").textContent = e.message; $("error").hidden = false; }
  }
  $("pause").onclick = () => act("POST", "pause");
  $("resume").onclick = () => act("POST", "resume");
  $("skip").onclick = () => { if (E.state && E.state.trial_id) act("POST", "skip", { trial_id: E.state.trial_id }); };
  $("add-note").onclick = async () => {
    const text = $("note").value.trim();
    if (!text) return;
    await act("POST", "note", { text });
    const li = document.createElement("li"); li.textContent = `${new Date().toLocaleTimeString()}: ${text}`;
    $("notes").prepend(li); $("note").value = ""; E.notes += 1;
  };
  act("GET", "state");
  setInterval(() => act("GET", "state"), 1000);
})();

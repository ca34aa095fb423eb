// The rating page: sign in with a rater name, watch each replay left (play, pause, scrub,
// speed), rate it on the study's metrics and submit. Everything comes from this server.
"use strict";

const $ = (id) => document.getElementById(id);
const state = { study: null, rater: null, total: 0, left: [], replay: null, manifest: null, frame: 0, timer: null };

async function api(path, options) {
  const response = await fetch(path, options);
  let body = null;
  try { body = await response.json(); } catch (_) { body = null; }
  if (!response.ok) throw new Error((body && body.error) || `${response.status} ${response.statusText}`);
  return body;
}

function view(name) {
  for (const id of ["login", "rate", "done"]) $(id).hidden = id !== name;
  document.body.dataset.state = name;
}

function frameUrl(i) {
  return `/replays/${state.replay}/${String(i).padStart(6, "0")}.png`;
}

function show(i) {
  const m = state.manifest;
  state.frame = Math.max(0, Math.min(i, m.frames - 1));
  $("frame").src = frameUrl(state.frame);
  $("scrub").value = String(state.frame);
  $("pos").textContent = `${state.frame + 1} / ${m.frames}`;
  document.body.dataset.frame = String(state.frame);
  // Fetch the next frames ahead so playback does not wait on the network.
  for (let k = 1; k <= 4 && state.frame + k < m.frames; k++) new Image().src = frameUrl(state.frame + k);
}

function delay() {
  return (state.manifest.step_seconds * 1000) / Number($("speed").value);
}

function pause() {
  if (state.timer !== null) clearTimeout(state.timer);
  state.timer = null;
  $("play").textContent = "Play";
}

function tick() {
  if (state.frame >= state.manifest.frames - 1) { pause(); return; }
  show(state.frame + 1);
  state.timer = setTimeout(tick, delay());
}

function togglePlay() {
  if (state.timer !== null) { pause(); return; }
  if (state.frame >= state.manifest.frames - 1) show(0);
  $("play").textContent = "Pause";
  state.timer = setTimeout(tick, delay());
}

function buildMetrics() {
  const box = $("metrics");
  box.replaceChildren();
  for (const m of state.study.metrics) {
    const set = document.createElement("fieldset");
    const legend = document.createElement("legend");
    legend.textContent = m.name;
    const q = document.createElement("p");
    q.className = "question";
    q.textContent = m.question;
    const scale = document.createElement("div");
    scale.className = "scale";
    const low = document.createElement("span");
    low.className = "end";
    low.textContent = `1 = ${m.low}`;
    scale.append(low);
    for (let v = 1; v <= 5; v++) {
      const label = document.createElement("label");
      const input = document.createElement("input");
      input.type = "radio";
      input.name = m.key;
      input.value = String(v);
      input.required = true;
      label.append(input, ` ${v}`);
      scale.append(label);
    }
    const high = document.createElement("span");
    high.className = "end";
    high.textContent = `5 = ${m.high}`;
    scale.append(high);
    set.append(legend, q, scale);
    box.append(set);
  }
}

async function next() {
  pause();
  const r = await api(`/api/rater/${encodeURIComponent(state.rater)}`);
  state.total = r.total;
  state.left = r.left;
  $("progress").textContent = `${r.done} of ${r.total} rated`;
  if (state.left.length === 0) { view("done"); return; }
  state.replay = state.left[0];
  state.manifest = await api(`/replays/${state.replay}/manifest.json`);
  $("replay-title").textContent = `Replay ${r.done + 1} of ${r.total}`;
  $("scrub").max = String(state.manifest.frames - 1);
  $("rating-form").reset();
  $("message").textContent = "";
  document.body.dataset.replay = state.replay;
  show(0);
  view("rate");
}

async function signIn(event) {
  event.preventDefault();
  const name = $("rater").value.trim();
  if (!/^[A-Za-z0-9_-]{1,32}$/.test(name)) {
    $("login-message").textContent = "Use 1 to 32 letters, digits, _ or -.";
    return;
  }
  state.rater = name;
  try { localStorage.setItem("avacraft-rater", name); } catch (_) { /* private mode */ }
  $("who").textContent = `Rater: ${name}`;
  try { await next(); } catch (e) { $("login-message").textContent = e.message; }
}

async function submit(event) {
  event.preventDefault();
  const form = $("rating-form");
  const rating = { rater: state.rater, replay: state.replay, comment: $("comment").value };
  for (const m of state.study.metrics) {
    const checked = form.querySelector(`input[name="${m.key}"]:checked`);
    if (!checked) { $("message").textContent = `Rate "${m.name}" first.`; return; }
    rating[m.key] = Number(checked.value);
  }
  $("submit").disabled = true;
  try {
    await api("/api/ratings", { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(rating) });
    await next();
  } catch (e) {
    $("message").textContent = e.message;
  } finally {
    $("submit").disabled = false;
  }
}

async function main() {
  try {
    state.study = await api("/api/study");
  } catch (e) {
    document.body.textContent = `The study could not be loaded: ${e.message}`;
    return;
  }
  buildMetrics();
  $("login-form").addEventListener("submit", signIn);
  $("rating-form").addEventListener("submit", submit);
  $("play").addEventListener("click", togglePlay);
  $("scrub").addEventListener("input", () => { pause(); show(Number($("scrub").value)); });
  $("speed").addEventListener("change", () => {
    if (state.timer !== null) { clearTimeout(state.timer); state.timer = setTimeout(tick, delay()); }
  });
  try { $("rater").value = localStorage.getItem("avacraft-rater") || ""; } catch (_) { /* private mode */ }
  view("login");
}

main();

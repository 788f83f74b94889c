// Argand's front end: plain ES module, no build step, data only from the API.

const view = document.getElementById("view");
const h = (html) => { const t = document.createElement("template"); t.innerHTML = html.trim(); return t.content; };
const esc = (s) => String(s ?? "").replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c]));
let cleanup = () => {};

// The farm's API token, when it has one: asked once (on the first 401), kept
// for this tab's session in sessionStorage, sent as a header (never a cookie,
// so another site cannot make the browser send it).
const TOKEN_KEY = "argand-api-token";
function authHeaders() {
  const token = sessionStorage.getItem(TOKEN_KEY);
  return token ? { authorization: `Bearer ${token}` } : {};
}

async function api(path, options = {}, asked = false) {
  const r = await fetch(path, { ...options, headers: { "content-type": "application/json", ...authHeaders(), ...(options.headers || {}) } });
  if (r.status === 401 && !asked) {
    const token = window.prompt("This farm needs its API token (ARGAND_API_TOKEN):");
    if (token) { sessionStorage.setItem(TOKEN_KEY, token.trim()); return api(path, options, true); }
  }
  const body = r.status === 204 ? null : await r.json().catch(() => null);
  if (!r.ok) throw new Error(body?.detail ? (typeof body.detail === "string" ? body.detail : JSON.stringify(body.detail)) : `HTTP ${r.status}`);
  return body;
}

// The farm's definitions (states, actions, pixel statuses and their colours,
// channels, limits, a new job's defaults), read once from the API: no copies here.
let meta = null;
async function loadMeta() { meta = meta || await api("/api/meta"); return meta; }
const ended = (status) => meta.ended_states.includes(status);

function fmtEta(s) { return s == null ? "" : s < 60 ? `${Math.round(s)} s` : `${Math.floor(s / 60)} min ${Math.round(s % 60)} s`; }
function pct(x) { return `${Math.round(100 * x)}%`; }

// ---------------------------------------------------------------- jobs list
async function jobsPage() {
  view.replaceChildren(h(`<h1>Jobs</h1>
    <div class="controls"><label>Status <select id="filter" aria-label="Filter by status">
      <option value="">all</option>${meta.job_states.map((s) => `<option>${s}</option>`).join("")}
    </select></label></div><div id="table"><p class="muted">Loading jobs…</p></div>`));
  const filter = view.querySelector("#filter");
  filter.value = new URLSearchParams(location.hash.split("?")[1]).get("status") || "";
  const render = async () => {
    try {
      const q = filter.value ? `?status=${filter.value}` : "";
      const { jobs } = await api(`/api/jobs${q}`);
      const table = view.querySelector("#table");
      if (!jobs.length) { table.replaceChildren(h(`<p class="muted">No jobs yet. <a href="#/new">Submit one</a>.</p>`)); return; }
      table.replaceChildren(h(`<table><thead><tr><th></th><th>Scene</th><th>Frames</th><th>Status</th><th>Progress</th><th>ETA</th><th>Priority</th><th>Actions</th></tr></thead><tbody>
        ${jobs.map((j) => {
          const thumb = j.frames.find((f) => f.thumbnail_url);
          return `<tr data-job="${j.id}">
          <td>${thumb ? `<img src="${thumb.thumbnail_url}" alt="">` : ""}</td>
          <td><a href="#/job/${j.id}">${esc(j.scene_name)}</a><div class="muted">${j.width}×${j.height}</div></td>
          <td>${j.frames.length}</td>
          <td><span class="badge ${j.status}">${j.status}</span></td>
          <td><div class="bar" role="progressbar" aria-valuenow="${Math.round(100 * j.progress)}" aria-valuemin="0" aria-valuemax="100"><span style="width:${pct(j.progress)}"></span></div></td>
          <td>${fmtEta(j.eta_s)}</td>
          <td><input type="number" min="0" max="9" value="${j.priority}" aria-label="Priority" data-priority style="width:4rem"></td>
          <td>${Object.keys(meta.actions).map((a) => `<button data-action="${a}"${meta.actions[a].includes(j.status) ? "" : " disabled"}>${a}</button>`).join(" ")}</td></tr>`;
        }).join("")}</tbody></table>`));
    } catch (e) { view.querySelector("#table").replaceChildren(h(`<p class="error">${esc(e.message)}</p>`)); }
  };
  const table = view.querySelector("#table");  // new on every visit: listeners do not pile up
  table.addEventListener("click", async (ev) => {
    const b = ev.target.closest("button[data-action]"); if (!b) return;
    const id = b.closest("tr").dataset.job;
    try { await api(`/api/jobs/${id}/${b.dataset.action}`, { method: "POST" }); render(); } catch (e) { alert(e.message); }
  });
  table.addEventListener("change", async (ev) => {
    if (ev.target.matches("[data-priority]")) {
      const id = ev.target.closest("tr").dataset.job;
      try { await api(`/api/jobs/${id}`, { method: "PATCH", body: JSON.stringify({ priority: Number(ev.target.value) }) }); } catch (e) { alert(e.message); }
    }
  });
  filter.addEventListener("change", render);
  await render();
  const timer = setInterval(render, 2000);
  cleanup = () => clearInterval(timer);
}

// ---------------------------------------------------------------- new job
async function newPage() {
  view.replaceChildren(h(`<h1>New job</h1><p class="muted">Pick a preset, or write a surface.</p>
    <div class="gallery" id="gallery" role="group" aria-label="Presets"><span class="muted">Loading presets…</span></div>
    <form class="grid" id="form" novalidate>
      <label class="wide">Surface F(x, y, z) = 0 (or a preset above)
        <input id="surface" name="surface" placeholder="x^2*z + y^2" autocomplete="off" aria-describedby="surface-msg">
        <span id="surface-msg" class="muted"></span></label>
      <label>Clip radius <input id="clip" type="number" step="any" min="0" value="2"></label>
      <label>σ (sigma) <input id="sigma" value="0"></label>
      <label>δ from <input id="start" value="0"></label>
      <label>δ to <input id="stop" value="pi/9"></label>
      <label>Frames <input id="count" type="number" min="1" max="${meta.limits.max_frames}" value="12"></label>
      <label>Width <input id="width" type="number" min="8" max="${meta.limits.max_width}" value="${meta.defaults.width}"></label>
      <label>Height <input id="height" type="number" min="8" max="${meta.limits.max_height}" value="${meta.defaults.height}"></label>
      <label>Tile <input id="tile" type="number" min="${meta.limits.min_tile}" max="${meta.limits.max_tile}" value="${meta.defaults.tile}"></label>
      <label>Priority <input id="priority" type="number" min="${meta.limits.priority[0]}" max="${meta.limits.priority[1]}" value="${meta.defaults.priority}"></label>
      <label>Samples per pixel <select id="samples">${meta.limits.samples.map((n) => `<option${n === meta.defaults.samples ? " selected" : ""}>${n}</option>`).join("")}</select></label>
      <div class="wide"><button class="primary" type="submit" id="submit">Render</button> <span id="form-msg" class="error"></span></div>
    </form>`));
  let preset = null;
  const surface = view.querySelector("#surface"), msg = view.querySelector("#surface-msg");
  try {
    const presets = await api("/api/presets");
    view.querySelector("#gallery").replaceChildren(h(presets.map((p) =>
      `<button type="button" class="preset" data-preset="${p.name}" aria-pressed="false"><img src="/api/presets/${p.name}/thumbnail.png" alt="" loading="lazy">${p.name}</button>`).join("")));
  } catch (e) { view.querySelector("#gallery").replaceChildren(h(`<p class="error">${esc(e.message)}</p>`)); }
  view.querySelector("#gallery").addEventListener("click", (ev) => {
    const b = ev.target.closest("[data-preset]"); if (!b) return;
    preset = b.dataset.preset;
    view.querySelectorAll(".preset").forEach((x) => x.setAttribute("aria-pressed", String(x === b)));
    surface.value = ""; msg.textContent = `preset ${preset}`; msg.className = "muted";
  });
  let seq = 0, surfaceError = null;
  surface.addEventListener("input", async () => {
    preset = null; view.querySelectorAll(".preset").forEach((x) => x.setAttribute("aria-pressed", "false"));
    const mine = ++seq; const text = surface.value; surfaceError = "still checking";
    if (!text.trim()) { msg.textContent = ""; return; }
    const v = await api("/api/scenes/validate", { method: "POST", body: JSON.stringify({ surface: text }) }).catch((e) => ({ valid: false, message: e.message }));
    if (mine !== seq) return;
    if (v.valid) { msg.textContent = `degree ${v.degree}`; msg.className = "muted"; surfaceError = null; view.querySelector("#form-msg").textContent = ""; }
    else { msg.textContent = v.message || v.error; msg.className = "error"; surfaceError = v.error || "invalid surface"; }
  });
  view.querySelector("#form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const val = (id) => view.querySelector(`#${id}`).value;
    const formMsg = view.querySelector("#form-msg"); formMsg.textContent = "";
    let scene = preset;
    if (!scene) {
      if (!surface.value.trim()) { formMsg.textContent = "choose a preset or write a surface"; return; }
      if (surfaceError) { formMsg.textContent = `fix the surface first: ${surfaceError}`; return; }
      const obj = { surface: surface.value };
      if (Number(val("clip")) > 0) obj.clip_radius = Number(val("clip"));
      scene = { objects: [obj] };
    }
    const body = { scene, sigma: val("sigma"), deltas: { start: val("start"), stop: val("stop"), count: Number(val("count")) },
      width: Number(val("width")), height: Number(val("height")), tile: Number(val("tile")), priority: Number(val("priority")),
      samples: Number(val("samples")) };
    try { const job = await api("/api/jobs", { method: "POST", body: JSON.stringify(body) }); location.hash = `#/job/${job.id}`; }
    catch (e) { formMsg.textContent = e.message; }
  });
}

// ---------------------------------------------------------------- job page
async function jobPage(id) {
  view.replaceChildren(h(`<p class="muted">Loading job…</p>`));
  let job;
  try { job = await api(`/api/jobs/${id}`); } catch (e) { view.replaceChildren(h(`<p class="error">${esc(e.message)}</p>`)); return; }
  view.replaceChildren(h(`<h1>${esc(job.scene_name)} <span class="badge ${job.status}" id="status">${job.status}</span></h1>
    <div class="bar" role="progressbar" aria-label="Progress" id="progress"><span style="width:${pct(job.progress)}"></span></div>
    <p class="muted" id="progress-text"></p>
    <div class="player"><div>
      <canvas id="canvas" width="${job.width}" height="${job.height}" aria-label="Frame"></canvas>
      <div class="controls">
        <button id="play" aria-label="Play or pause (space)">▶ play</button>
        <button id="prev" aria-label="Previous frame (left arrow)">◀</button>
        <button id="next" aria-label="Next frame (right arrow)">▶</button>
        <label>mode <select id="mode"><option value="loop">loop</option><option value="pingpong">ping-pong</option></select></label>
        <label>fps <input id="fps" type="number" min="1" max="60" value="8" style="width:4rem"></label>
        <label>channel <select id="channel" aria-label="Channel">${meta.channels.map((c) => `<option>${c}</option>`).join("")}</select></label>
      </div>
      <input id="scrub" type="range" min="0" max="${job.frames.length - 1}" value="0" style="width:100%" aria-label="Frame (delta)">
      <div id="scrub-label" class="muted"></div>
      <div id="legend" class="legend muted" hidden>status:${meta.pixel_statuses.map((p) => `<span style="background:${p.colour}"></span>${p.name}`).join("")}</div>
    </div><aside><h2 style="font-size:1rem">Frame</h2><dl id="figures"></dl>
      <h2 style="font-size:1rem">Downloads</h2><div id="downloads" class="muted">when the frames are done</div></aside></div>
    <div class="frames" id="grid"></div>`));
  const canvas = view.querySelector("#canvas"), ctx = canvas.getContext("2d");
  const scrub = view.querySelector("#scrub"), channel = view.querySelector("#channel");
  const images = new Map();  // `${channel}/${index}` -> HTMLImageElement (preloaded)
  let current = 0, playing = false, dir = 1, timer = null;
  const url = (f, ch) => ch === "beauty" ? f.png_url : `/api/jobs/${id}/frames/${f.index}/${ch}.png`;
  function image(f, ch) {
    const key = `${ch}/${f.index}`;
    if (!images.has(key) && f.status === "done") { const img = new Image(); img.src = url(f, ch); images.set(key, img); }
    return images.get(key);
  }
  function show(i) {
    current = i; scrub.value = i;
    const f = job.frames[i];
    view.querySelector("#scrub-label").textContent = `frame ${i + 1}/${job.frames.length} — δ = ${f.delta.toFixed(4)}, σ = ${f.sigma.toFixed(4)}`;
    canvas.dataset.frame = String(i);
    const img = image(f, channel.value);
    const draw = () => { ctx.drawImage(img, 0, 0, canvas.width, canvas.height); canvas.dataset.drawn = `${channel.value}/${i}`; };
    if (img) { img.complete && img.naturalWidth ? draw() : img.addEventListener("load", draw, { once: true }); }
    else { ctx.fillStyle = "#000"; ctx.fillRect(0, 0, canvas.width, canvas.height); canvas.dataset.drawn = ""; }
    const fig = f.figures || {};
    view.querySelector("#figures").replaceChildren(h(`<dt>δ</dt><dd>${f.delta.toFixed(5)}</dd><dt>status</dt><dd>${f.status}</dd>
      <dt>certified</dt><dd>${f.certified_share == null ? "—" : (100 * f.certified_share).toFixed(3) + "%"}</dd>
      <dt>render time</dt><dd>${fig.seconds == null ? "—" : (1000 * fig.seconds).toFixed(0) + " ms"}</dd>
      <dt>escalated</dt><dd>${fig.escalated_share == null ? "—" : (100 * fig.escalated_share).toFixed(3) + "%"}</dd>`));
    view.querySelectorAll("#grid .cell").forEach((c) => c.classList.toggle("current", Number(c.dataset.index) === i));
  }
  function step(d) {
    const n = job.frames.length; if (n < 2) return show(0);
    if (view.querySelector("#mode").value === "pingpong") {
      let k = current + d * dir; if (k < 0 || k >= n) { dir = -dir; k = current + d * dir; } show(k);
    } else show((current + d + n) % n);
  }
  function setPlaying(p) {
    playing = p; clearInterval(timer);
    view.querySelector("#play").textContent = p ? "❚❚ pause" : "▶ play";
    if (p) timer = setInterval(() => step(1), 1000 / Math.max(1, Number(view.querySelector("#fps").value) || 8));
  }
  function refresh(j) {
    job = j;
    view.querySelector("#status").textContent = j.status; view.querySelector("#status").className = `badge ${j.status}`;
    view.querySelector("#progress > span").style.width = pct(j.progress);
    view.querySelector("#progress-text").textContent = `${j.tiles_done}/${j.tiles_total} tiles${j.eta_s ? ", about " + fmtEta(j.eta_s) + " left" : ""}`;
    view.querySelector("#grid").replaceChildren(h(j.frames.map((f) =>
      `<div class="cell" data-index="${f.index}" title="δ = ${f.delta.toFixed(4)}">${f.thumbnail_url ? `<img src="${f.thumbnail_url}" alt="frame ${f.index}">` : f.status}</div>`).join("")));
    j.frames.forEach((f) => image(f, channel.value));
    if (j.status === "done") {
      view.querySelector("#downloads").replaceChildren(h(`${j.animation_url ? `<p><a id="gif" href="${j.animation_url}" download>animation.gif</a> · <a id="webp" href="${j.webp_url}" download>animation.webp</a></p>` : ""}
        <details><summary>frames</summary>${j.frames.map((f) => `<div>${f.index}: <a href="${f.png_url}" download>PNG</a> <a href="${f.exr_url}" download>EXR</a></div>`).join("")}</details>`));
    }
    show(Math.min(current, j.frames.length - 1));
  }
  refresh(job);
  view.querySelector("#play").addEventListener("click", () => setPlaying(!playing));
  view.querySelector("#prev").addEventListener("click", () => { setPlaying(false); step(-1); });
  view.querySelector("#next").addEventListener("click", () => { setPlaying(false); step(1); });
  view.querySelector("#fps").addEventListener("change", () => playing && setPlaying(true));
  scrub.addEventListener("input", () => { setPlaying(false); show(Number(scrub.value)); });
  channel.addEventListener("change", () => { view.querySelector("#legend").hidden = channel.value !== "status"; job.frames.forEach((f) => image(f, channel.value)); show(current); });
  view.querySelector("#grid").addEventListener("click", (ev) => { const c = ev.target.closest(".cell"); if (c) { setPlaying(false); show(Number(c.dataset.index)); } });
  const keys = (ev) => {
    if (ev.target.matches("input, select, textarea")) return;
    if (ev.key === " ") { ev.preventDefault(); setPlaying(!playing); }
    else if (ev.key === "ArrowRight") { setPlaying(false); step(1); }
    else if (ev.key === "ArrowLeft") { setPlaying(false); step(-1); }
  };
  document.addEventListener("keydown", keys);
  let source = null;
  if (!ended(job.status)) {
    source = new EventSource(`/api/jobs/${id}/events`);
    source.addEventListener("progress", async () => { try { refresh(await api(`/api/jobs/${id}`)); } catch { /* next event */ } });
    source.addEventListener("end", async () => { source.close(); refresh(await api(`/api/jobs/${id}`)); });
    source.onerror = () => { view.querySelector("#progress-text").textContent += " (reconnecting…)"; };
  }
  cleanup = () => { clearInterval(timer); document.removeEventListener("keydown", keys); source?.close(); };
}

// ---------------------------------------------------------------- workers
async function workersPage() {
  view.replaceChildren(h(`<h1>Workers</h1><div id="w"><p class="muted">Loading…</p></div>`));
  const render = async () => {
    try {
      const ws = await api("/api/workers");
      view.querySelector("#w").replaceChildren(h(ws.length ? `<table><thead><tr><th>Name</th><th>Host</th><th>Heartbeat</th><th>Current tile</th><th>Tiles done</th></tr></thead><tbody>
        ${ws.map((w) => `<tr><td>${esc(w.name)} ${w.alive ? "" : '<span class="badge failed">silent</span>'}</td><td>${esc(w.host)}</td>
        <td>${Math.max(0, Math.round(Date.now() / 1000 - w.heartbeat))} s ago</td><td>${esc(w.current_tile || "—")}</td><td>${w.tiles_done}</td></tr>`).join("")}</tbody></table>`
        : `<p class="muted">No workers have reported yet.</p>`));
    } catch (e) { view.querySelector("#w").replaceChildren(h(`<p class="error">${esc(e.message)}</p>`)); }
  };
  await render();
  const timer = setInterval(render, 2000);
  cleanup = () => clearInterval(timer);
}

// ---------------------------------------------------------------- compare
async function comparePage() {
  const params = new URLSearchParams(location.hash.split("?")[1] || "");
  view.replaceChildren(h(`<h1>Compare</h1><p class="muted">Two frames, of one job or of two, side by side or under a slider.</p>
    <div class="controls" id="pickers"><span class="muted">Loading jobs…</span></div>
    <div class="controls"><label>view <select id="cmp-mode"><option value="side">side by side</option><option value="slider">slider</option></select></label>
      <input id="cmp-split" type="range" min="0" max="100" value="50" aria-label="Split position" hidden></div>
    <div id="cmp"></div>`));
  let jobs;
  try { jobs = (await api("/api/jobs?status=done&per_page=200")).jobs; }
  catch (e) { view.querySelector("#pickers").replaceChildren(h(`<p class="error">${esc(e.message)}</p>`)); return; }
  if (!jobs.length) { view.querySelector("#pickers").replaceChildren(h(`<p class="muted">No finished jobs to compare yet.</p>`)); return; }
  const opts = jobs.flatMap((j) => j.frames.map((f) => `<option value="${j.id}:${f.index}">${esc(j.scene_name)} ${j.id.slice(0, 6)} — δ=${f.delta.toFixed(4)}</option>`)).join("");
  view.querySelector("#pickers").replaceChildren(h(`<label>left <select id="cmp-a">${opts}</select></label><label>right <select id="cmp-b">${opts}</select></label>`));
  const a = view.querySelector("#cmp-a"), b = view.querySelector("#cmp-b"), mode = view.querySelector("#cmp-mode"), split = view.querySelector("#cmp-split");
  if (params.get("a")) a.value = params.get("a");
  b.value = params.get("b") || b.options[Math.min(1, b.options.length - 1)].value;
  const src = (v) => { const [id, i] = v.split(":"); return `/api/jobs/${id}/frames/${i}.png`; };
  function render() {
    const box = view.querySelector("#cmp");
    split.hidden = mode.value !== "slider";
    if (mode.value === "side") {
      box.replaceChildren(h(`<div style="display:grid;grid-template-columns:1fr 1fr;gap:.8rem"><img id="img-a" src="${src(a.value)}" alt="left frame" style="width:100%"><img id="img-b" src="${src(b.value)}" alt="right frame" style="width:100%"></div>`));
    } else {
      box.replaceChildren(h(`<div style="position:relative;max-width:720px"><img id="img-a" src="${src(a.value)}" alt="left frame" style="width:100%;display:block">
        <img id="img-b" src="${src(b.value)}" alt="right frame" style="width:100%;position:absolute;inset:0;clip-path:inset(0 0 0 ${split.value}%)"></div>`));
    }
  }
  [a, b, mode].forEach((el) => el.addEventListener("change", render));
  split.addEventListener("input", () => { const img = view.querySelector("#img-b"); if (img) img.style.clipPath = `inset(0 0 0 ${split.value}%)`; });
  render();
}

// ---------------------------------------------------------------- router
async function route() {
  cleanup(); cleanup = () => {};
  try { await loadMeta(); } catch (e) { view.replaceChildren(h(`<p class="error">${esc(e.message)}</p>`)); return; }
  const [path] = location.hash.replace(/^#/, "").split("?");
  const parts = path.split("/").filter(Boolean);
  document.querySelectorAll("nav a[data-nav]").forEach((a) => a.classList.toggle("active", a.dataset.nav === (parts[0] || "jobs")));
  if (parts[0] === "new") return newPage();
  if (parts[0] === "job" && parts[1]) return jobPage(parts[1]);
  if (parts[0] === "workers") return workersPage();
  if (parts[0] === "compare") return comparePage();
  return jobsPage();
}
window.addEventListener("hashchange", route);
route();

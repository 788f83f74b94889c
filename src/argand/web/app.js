// Argand's front end: plain ES module, no build step, data only from the API.
import { attach as attachBands } from "./bands.js";

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

function fmtEta(s) { return s == null ? "" : s < 1 ? "under 1 s" : s < 60 ? `${Math.round(s)} s` : `${Math.floor(s / 60)} min ${Math.round(s % 60)} s`; }
function pct(x) { return `${Math.round(100 * x)}%`; }
// A frame's angles as the API writes them (π fractions where they are: "π/36").
const sigmaOf = (_j, f) => f.sigma_label;
const deltaOf = (_j, f) => f.delta_label;

// The user's actions on a job, each enabled only in the states it applies to
// (meta.actions), and delete, which always applies.
function actionButtons(j) {
  return Object.keys(meta.actions).map((a) => `<button type="button" data-action="${a}"${meta.actions[a].includes(j.status) ? "" : " disabled"}>${a}</button>`).join(" ")
    + ` <button type="button" class="danger" data-delete>delete</button>`;
}
// Runs the clicked action (a delete after a confirmation); returns the job
// after it, null after a delete, undefined when nothing was clicked or done.
async function runAction(ev, id) {
  const b = ev.target.closest("button[data-action], button[data-delete]"); if (!b || b.disabled) return undefined;
  try {
    if (b.dataset.delete !== undefined) {
      if (!window.confirm("Delete this job and its files?")) return undefined;
      await api(`/api/jobs/${id}`, { method: "DELETE" });
      return null;
    }
    return await api(`/api/jobs/${id}/${b.dataset.action}`, { method: "POST" });
  } catch (e) { alert(e.message); return undefined; }
}

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
      if (!table) return;  // the user has left the page
      if (!jobs.length) { table.replaceChildren(h(`<p class="muted">No jobs yet. <a href="#/new">Submit one</a>.</p>`)); return; }
      table.replaceChildren(h(`<table><thead><tr><th></th><th>Scene</th><th>Frames</th><th>Status</th><th>Progress</th><th>ETA</th><th>Priority</th><th>Actions</th></tr></thead><tbody>
        ${jobs.map((j) => {
          return `<tr data-job="${j.id}">
          <td>${j.thumbnail_url ? `<img src="${j.thumbnail_url}" alt="">` : ""}</td>
          <td><a href="#/job/${j.id}">${esc(j.scene_name)}</a><div class="muted">${j.width}×${j.height}</div></td>
          <td>${j.frames_total}${j.sigma_count > 1 && j.delta_count > 1 ? `<div class="muted">${j.sigma_count} σ × ${j.delta_count} δ</div>` : ""}</td>
          <td><span class="badge ${j.status}">${j.status}</span>${j.error ? `<div class="muted job-error" title="${esc(j.error)}">${esc(j.error)}</div>` : ""}</td>
          <td><div class="bar" role="progressbar" aria-valuenow="${Math.round(100 * j.progress)}" aria-valuemin="0" aria-valuemax="100"><span style="width:${pct(j.progress)}"></span></div></td>
          <td>${j.eta_s == null ? '<span class="muted">—</span>' : fmtEta(j.eta_s)}</td>
          <td><input type="number" min="0" max="9" value="${j.priority}" aria-label="Priority" data-priority style="width:4rem"></td>
          <td class="actions">${actionButtons(j)}</td></tr>`;
        }).join("")}</tbody></table>`));
    } catch (e) { view.querySelector("#table")?.replaceChildren(h(`<p class="error">${esc(e.message)}</p>`)); }
  };
  const table = view.querySelector("#table");  // new on every visit: listeners do not pile up
  table.addEventListener("click", async (ev) => {
    const row = ev.target.closest("tr[data-job]"); if (!row) return;
    if (await runAction(ev, row.dataset.job) !== undefined) render();
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
      <label>σ from <input id="sigma" value="0"></label>
      <label>σ to <input id="sigma-stop" value="0"></label>
      <label>σ values <input id="sigma-count" type="number" min="1" max="${meta.limits.max_frames}" value="1"></label>
      <label>δ from <input id="start" value="0"></label>
      <label>δ to <input id="stop" value="pi/9"></label>
      <label>Frames (δ values) <input id="count" type="number" min="1" max="${meta.limits.max_frames}" value="12"></label>
      <label class="wide check"><span><input id="atlas" type="checkbox"> Atlas: the whole space σ ≥ 0, σ + δ ≤ π on a triangular grid of
        <input id="atlas-steps" type="number" min="1" max="${Math.floor((Math.sqrt(8 * meta.limits.max_frames + 1) - 1) / 2)}" value="6" style="width:4rem" aria-label="Atlas steps"> steps (step π/N; replaces the σ and δ values)</span></label>
      <label class="wide check"><span><input id="atlas-roots" type="checkbox"> Atlas cut where the roots are (denser where the scene's roots' arguments are, not every π/N)</span></label>
      <label>Width <input id="width" type="number" min="8" max="${meta.limits.max_width}" value="${meta.defaults.width}"></label>
      <label>Height <input id="height" type="number" min="8" max="${meta.limits.max_height}" value="${meta.defaults.height}"></label>
      <label>Tile <input id="tile" type="number" min="${meta.limits.min_tile}" max="${meta.limits.max_tile}" step="${meta.limits.tile_multiple}" value="${meta.defaults.tile}"></label>
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
    const sigmaCount = Number(val("sigma-count"));
    const frames = view.querySelector("#atlas").checked ? { atlas: Number(val("atlas-steps")),
      ...(view.querySelector("#atlas-roots").checked ? { atlas_layout: "roots" } : {}) } : {
      sigmas: sigmaCount > 1 ? { start: val("sigma"), stop: val("sigma-stop"), count: sigmaCount } : val("sigma"),
      deltas: { start: val("start"), stop: val("stop"), count: Number(val("count")) } };
    const body = { scene, ...frames,
      width: Number(val("width")), height: Number(val("height")), tile: Number(val("tile")), priority: Number(val("priority")),
      samples: Number(val("samples")) };
    try { const job = await api("/api/jobs", { method: "POST", body: JSON.stringify(body) }); location.hash = `#/job/${job.id}`; }
    catch (e) { formMsg.textContent = e.message; }
  });
}

// ---------------------------------------------------------------- job page
// A job's frames are (σ, δ) pairs on a grid (row: sigma_index, column:
// delta_index): a δ sweep is one row, a σ sweep one column, an atlas a
// triangle. The player moves along either axis through the current frame.
function jobMissing(message) {
  view.replaceChildren(h(`<h1>Job not found</h1><p class="error" id="job-error">${esc(message)}</p>
    <p>It may have been deleted, or the address is wrong. <a href="#/jobs" id="back">← Back to the jobs</a></p>`));
}

// What the job is doing, in words: the ETA only while it runs; a stopped
// job (paused, canceled, failed) says where it stopped, why, and which
// actions take it up again (those of meta.actions that do not apply to a
// running job).
function progressText(j) {
  const tiles = `${j.tiles_done}/${j.tiles_total} tiles`, done = j.frames.filter((f) => f.status === "done").length;
  const frames = `${done} of ${j.frames.length} frame${j.frames.length === 1 ? "" : "s"} done`;
  if (j.status === "done") return `done: ${frames}${j.started && j.finished ? ` in ${fmtEta(j.finished - j.started)}` : ""}`;
  if (j.eta_s != null) return `${tiles}, ${frames}, about ${fmtEta(j.eta_s)} left`;
  if (j.status === "queued") return `queued: waiting for a worker (${tiles})`;
  if (j.status === "running") return `${tiles}, ${frames}`;
  const next = Object.keys(meta.actions).filter((a) => meta.actions[a].includes(j.status) && !meta.actions[a].includes("running"));
  return `${j.status} at ${tiles}, ${frames}${j.error ? `: ${j.error}` : ""}${next.length ? ` (${next.join(" or ")} to go on)` : ""}`;
}

async function jobPage(id) {
  view.replaceChildren(h(`<p class="muted">Loading job…</p>`));
  let job;
  try { job = await api(`/api/jobs/${id}`); } catch (e) { jobMissing(e.message); return; }
  view.replaceChildren(h(`<h1>${esc(job.scene_name)} <span class="badge ${job.status}" id="status">${job.status}</span></h1>
    <div class="controls" id="actions" aria-label="Job actions"></div>
    <div class="bar" role="progressbar" aria-label="Progress" id="progress"><span style="width:${pct(job.progress)}"></span></div>
    <p class="muted" id="progress-text"></p>
    <div class="player"><div class="stage-column">
      <div class="stage" id="stage">
        <canvas id="canvas" width="${job.width}" height="${job.height}" aria-label="Frame"></canvas>
        <video id="video" width="${job.width}" height="${job.height}" controls loop muted playsinline hidden aria-label="Animation (MP4)"></video>
      </div>
      <div class="transport" id="transport">
        <div class="controls">
          <button id="play" aria-label="Play or pause (space)">▶ play</button>
          <button id="prev" aria-label="Previous frame (left arrow)">◀</button>
          <button id="next" aria-label="Next frame (right arrow)">▶</button>
          <label class="slider">δ <input id="scrub" type="range" min="0" max="0" value="0" aria-label="Frame along δ (left and right arrows)"></label>
        </div>
        <label class="slider">σ <input id="scrub-sigma" type="range" min="0" max="0" value="0" aria-label="Frame along σ (up and down arrows)"></label>
        <div id="scrub-label" class="muted" aria-live="off"></div>
      </div>
    </div><aside>
      <div class="controls settings" aria-label="Player settings">
        <label>along <select id="play-axis" aria-label="Play along"><option value="delta">δ</option><option value="sigma">σ</option></select></label>
        <label>mode <select id="mode"><option value="loop">loop</option><option value="pingpong">ping-pong</option></select></label>
        <label>fps <input id="fps" type="number" min="1" max="60" value="8" style="width:4rem"></label>
        <label>channel <select id="channel" aria-label="Channel">${meta.channels.map((c) => `<option>${c}</option>`).join("")}</select></label>
        <button id="show-mp4" hidden aria-pressed="false">MP4</button>
      </div>
      <div id="legend" class="legend muted" hidden>status:${meta.pixel_statuses.map((p) => `<span style="background:${p.colour}"></span>${p.name}`).join("")}
        <span style="background:${meta.status_empty.colour};outline:1px solid var(--line)"></span>dark: ${esc(meta.status_empty.meaning)}</div>
      <h2 style="font-size:1rem">Frame</h2><dl id="figures"></dl>
      <h2 style="font-size:1rem">Downloads</h2><div id="downloads" class="muted">No frame is done yet.</div></aside></div>
    <h2 id="atlas-title" style="font-size:1rem">Frames</h2>
    <div class="frames" id="grid"></div>`));
  const canvas = view.querySelector("#canvas"), ctx = canvas.getContext("2d"), video = view.querySelector("#video");
  const scrub = view.querySelector("#scrub"), scrubSigma = view.querySelector("#scrub-sigma"), channel = view.querySelector("#channel");
  const axisSelect = view.querySelector("#play-axis"), playButton = view.querySelector("#play");
  const stage = view.querySelector("#stage"), transport = view.querySelector("#transport");
  const images = new Map();  // `${channel}/${index}` -> HTMLImageElement (preloaded)
  let current = 0, playing = false, dir = 1, timer = null, gridKey = "";
  let live = true;  // false once the user has left the page (a late answer changes nothing)
  const isGrid = () => job.sigmas.length > 1 && job.deltas.length > 1;
  // The frames through the current one along an axis, in order.
  const line = (axis) => {
    const f = job.frames[current];
    return axis === "delta" ? job.frames.filter((g) => g.sigma_index === f.sigma_index).sort((a, b) => a.delta_index - b.delta_index)
                            : job.frames.filter((g) => g.delta_index === f.delta_index).sort((a, b) => a.sigma_index - b.sigma_index);
  };
  const url = (f, ch) => ch === "beauty" ? f.png_url : `/api/jobs/${id}/frames/${f.index}/${ch}.png`;
  function image(f, ch) {
    const key = `${ch}/${f.index}`;
    if (!images.has(key) && f.status === "done") { const img = new Image(); img.src = url(f, ch); images.set(key, img); }
    return images.get(key);
  }
  // Shows frame i: the label, sliders, figures and atlas follow; in MP4
  // mode the video is sought to it too, unless the video is what moved.
  function show(i, fromVideo = false) {
    current = i;
    if (!video.hidden && !fromVideo && video.readyState >= 1 && videoFrame(video.currentTime) !== i) video.currentTime = (i + 0.5) / mp4Fps();
    const f = job.frames[i];
    const row = line("delta"), col = line("sigma");
    scrub.max = row.length - 1; scrub.value = row.findIndex((g) => g.index === i);
    scrubSigma.max = col.length - 1; scrubSigma.value = col.findIndex((g) => g.index === i);
    view.querySelector("#scrub-label").textContent = `frame ${i + 1}/${job.frames.length} — δ = ${deltaOf(job, f)}, σ = ${sigmaOf(job, f)}`;
    canvas.dataset.frame = String(i);
    const img = image(f, channel.value);
    const draw = () => { ctx.drawImage(img, 0, 0, canvas.width, canvas.height); canvas.dataset.drawn = `${channel.value}/${i}`; };
    if (img) { img.complete && img.naturalWidth ? draw() : img.addEventListener("load", draw, { once: true }); }
    else { ctx.fillStyle = "#000"; ctx.fillRect(0, 0, canvas.width, canvas.height); canvas.dataset.drawn = ""; }
    const fig = f.figures || {};
    const exact = (label, v) => label.includes("π") ? `${label} <span class="muted">(${v.toFixed(5)})</span>` : label;
    view.querySelector("#figures").replaceChildren(h(`<dt>σ</dt><dd>${exact(sigmaOf(job, f), f.sigma)}</dd><dt>δ</dt><dd>${exact(deltaOf(job, f), f.delta)}</dd><dt>status</dt><dd>${f.status}</dd>
      <dt>certified</dt><dd>${f.certified_share == null ? "—" : (100 * f.certified_share).toFixed(3) + "%"}</dd>
      <dt>render time</dt><dd>${fig.seconds == null ? "—" : (1000 * fig.seconds).toFixed(0) + " ms"}</dd>
      <dt>escalated</dt><dd>${fig.escalated_share == null ? "—" : (100 * fig.escalated_share).toFixed(3) + "%"}</dd>`));
    view.querySelectorAll("#grid .cell").forEach((c) => c.classList.toggle("current", Number(c.dataset.index) === i));
  }
  // One step along an axis (wrapping, or bouncing in ping-pong mode).
  function step(d, axis = axisSelect.value) {
    const frames = line(axis), n = frames.length;
    const at = frames.findIndex((g) => g.index === current);
    if (n < 2) return show(current);
    let k;
    if (view.querySelector("#mode").value === "pingpong") {
      k = at + d * dir; if (k < 0 || k >= n) { dir = -dir; k = at + d * dir; }
    } else k = (at + d + n) % n;
    show(frames[k].index);
  }
  // Play or pause: the flipbook on the canvas, or in MP4 mode the video.
  function setPlaying(p) {
    playing = p; clearInterval(timer); timer = null;
    playButton.textContent = p ? "❚❚ pause" : "▶ play";
    if (!video.hidden) { if (p) video.play().catch(() => {}); else video.pause(); }
    else if (p) timer = setInterval(() => step(1), 1000 / Math.max(1, Number(view.querySelector("#fps").value) || 8));
  }
  // The picture's displayed size, the same for the canvas and the video: the
  // frame at the largest integer zoom (in device pixels) that fits the room
  // the page leaves it, above the transport and within the viewport's
  // height, with crisp pixels; a frame larger than that room is scaled down
  // to fit. Never a fractional stretch.
  function fit() {
    if (!live) return;
    const dpr = window.devicePixelRatio || 1;
    const top = stage.getBoundingClientRect().top + window.scrollY;
    const gap = parseFloat(getComputedStyle(transport).marginTop) || 0;
    const roomW = stage.clientWidth;
    const roomH = Math.max(96, window.innerHeight - top - gap - transport.offsetHeight - 12);
    const s = Math.min(roomW / job.width, roomH / job.height) * dpr;
    const zoom = s >= 1 ? Math.floor(s) : s;  // device pixels per frame pixel
    for (const el of [canvas, video]) {
      el.style.width = `${(job.width * zoom) / dpr}px`; el.style.height = `${(job.height * zoom) / dpr}px`;
      el.classList.toggle("zoomed", zoom > 1);
    }
    stage.dataset.zoom = String(+zoom.toFixed(4));
    transport.style.maxWidth = `${Math.max(360, (job.width * zoom) / dpr)}px`;  // the slider under the picture
  }
  // The MP4's frame rate: the job's when the API gives it, else the farm's
  // (animation.mp4 is encoded at 8 fps, every frame once, in index order).
  const mp4Fps = () => Number(job.fps) || 8;
  const videoFrame = (t) => Math.min(job.frames.length - 1, Math.max(0, Math.floor(t * mp4Fps() + 1e-3)));
  // While the MP4 plays (or is sought), the label, sliders and figures follow
  // its frame: each frame presented (requestVideoFrameCallback, where there
  // is one) and each timeupdate.
  const followVideo = (t) => { if (live && !video.hidden && job.frames.length) { const i = videoFrame(t); if (i !== current) show(i, true); } };
  let frameCallback = null;
  const onVideoFrame = (_now, m) => { followVideo(m.mediaTime); if (live) frameCallback = video.requestVideoFrameCallback(onVideoFrame); };
  if ("requestVideoFrameCallback" in video) frameCallback = video.requestVideoFrameCallback(onVideoFrame);
  ["timeupdate", "seeked"].forEach((e) => video.addEventListener(e, () => followVideo(video.currentTime)));
  video.addEventListener("play", () => { if (!video.hidden) { playing = true; playButton.textContent = "❚❚ pause"; } });
  video.addEventListener("pause", () => { if (!video.hidden) { playing = false; playButton.textContent = "▶ play"; } });
  // The frames as a contact sheet: one row per σ, one column per δ (an
  // atlas); a sweep along one axis is a strip of thumbnails.
  function cells(j) {
    const cell = (f) => `<button type="button" class="cell" data-index="${f.index}" data-sigma-index="${f.sigma_index}" data-delta-index="${f.delta_index}"
      title="σ = ${sigmaOf(j, f)}, δ = ${deltaOf(j, f)}" style="grid-row:${isGrid() ? f.sigma_index + 2 : "auto"};grid-column:${isGrid() ? f.delta_index + 2 : "auto"}">
      ${f.thumbnail_url ? `<img src="${f.thumbnail_url}" alt="frame ${f.index}">` : f.status}</button>`;
    if (!isGrid()) return j.frames.map(cell).join("");
    return `<span class="corner" style="grid-row:1;grid-column:1">σ ↓ δ →</span>`
      + j.delta_labels.map((d, c) => `<span class="axis" style="grid-row:1;grid-column:${c + 2}">${esc(d)}</span>`).join("")
      + j.sigma_labels.map((s, r) => `<span class="axis" style="grid-row:${r + 2};grid-column:1">${esc(s)}</span>`).join("")
      + j.frames.map(cell).join("");
  }
  // Any band of the job once it is done (bands.js): σ and δ sliders over the whole band rule.
  let bands = null;
  const bandsFollow = (j) => {
    if (!bands || (j.status === "done" && bands.section.dataset.done !== "yes")) {
      bands?.detach(); bands?.section.remove();
      bands = attachBands(view, j, authHeaders, view.querySelector("#atlas-title"));
    }
  };
  function refresh(j) {
    if (!live) return;
    job = j;
    bandsFollow(j);
    view.querySelector("#status").textContent = j.status; view.querySelector("#status").className = `badge ${j.status}`;
    view.querySelector("#progress > span").style.width = pct(j.progress);
    view.querySelector("#progress-text").textContent = progressText(j);
    const actions = view.querySelector("#actions");  // redrawn when the state changes, not under the pointer
    if (actions.dataset.status !== j.status) { actions.replaceChildren(h(actionButtons(j))); actions.dataset.status = j.status; }
    const grid = view.querySelector("#grid");
    grid.classList.toggle("atlas", isGrid());
    grid.style.gridTemplateColumns = isGrid() ? `auto repeat(${j.deltas.length}, minmax(48px, 96px))` : "";
    view.querySelector("#atlas-title").textContent = isGrid() ? `Atlas: ${j.sigmas.length} σ × ${j.deltas.length} δ (click a frame to open it)` : "Frames";
    const key = j.frames.map((f) => f.status).join();
    if (key !== gridKey) { gridKey = key; grid.replaceChildren(h(cells(j))); }
    j.frames.forEach((f) => image(f, channel.value));
    view.querySelector("#play-axis").closest("label").hidden = !isGrid();
    axisSelect.value = isGrid() ? axisSelect.value : (j.deltas.length > 1 ? "delta" : "sigma");
    scrub.closest("label").hidden = j.deltas.length < 2 && j.sigmas.length > 1;
    scrubSigma.closest("label").hidden = j.sigmas.length < 2;
    // Finished frames can be downloaded whatever the job's state; the
    // animations and the atlas once every frame is done.
    const finished = j.frames.filter((f) => f.png_url);
    view.querySelector("#show-mp4").hidden = !j.mp4_url;
    view.querySelector("#downloads").replaceChildren(h(finished.length ? `${j.animation_url ? `<p><a id="gif" href="${j.animation_url}" download>animation.gif</a> · <a id="webp" href="${j.webp_url}" download>animation.webp</a> · <a id="mp4" href="${j.mp4_url}" download>animation.mp4</a></p>` : ""}
        ${j.atlas_url ? `<p><a id="atlas-png" href="${j.atlas_url}" target="_blank">atlas.png</a> (the grid, labelled)</p>` : ""}
        <details id="frame-files"${j.status === "done" ? "" : " open"}><summary>${finished.length} of ${j.frames.length} frames</summary>${finished.map((f) => `<div>${f.index} (σ ${sigmaOf(j, f)}, δ ${deltaOf(j, f)}): <a href="${f.png_url}" download>PNG</a> <a href="${f.exr_url}" download>EXR</a> <a href="${f.json_url}" download>JSON</a></div>`).join("")}</details>`
      : `No frame is done yet.`));
    show(Math.min(current, j.frames.length - 1));
    fit();  // what is above the picture, or the σ slider, may have changed
  }
  refresh(job);
  window.addEventListener("resize", fit);
  // The MP4 in place of the canvas (the browser's own player), and back.
  view.querySelector("#show-mp4").addEventListener("click", (ev) => {
    const on = video.hidden;
    setPlaying(false);
    if (on && !video.src) video.src = job.mp4_url;
    video.hidden = !on; canvas.hidden = on; ev.target.setAttribute("aria-pressed", String(on));
    if (on) { video.currentTime = (current + 0.5) / mp4Fps(); setPlaying(true); }  // from the frame shown
    else show(current);  // the canvas at the frame the video was at
  });
  view.querySelector("#play").addEventListener("click", () => setPlaying(!playing));
  view.querySelector("#prev").addEventListener("click", () => { setPlaying(false); step(-1); });
  view.querySelector("#next").addEventListener("click", () => { setPlaying(false); step(1); });
  view.querySelector("#fps").addEventListener("change", () => playing && setPlaying(true));
  scrub.addEventListener("input", () => { setPlaying(false); show(line("delta")[Number(scrub.value)].index); });
  scrubSigma.addEventListener("input", () => { setPlaying(false); show(line("sigma")[Number(scrubSigma.value)].index); });
  channel.addEventListener("change", () => { view.querySelector("#legend").hidden = channel.value !== "status"; job.frames.forEach((f) => image(f, channel.value)); show(current); });
  view.querySelector("#grid").addEventListener("click", (ev) => { const c = ev.target.closest(".cell"); if (c) { setPlaying(false); show(Number(c.dataset.index)); } });
  const keys = (ev) => {
    if (ev.target.matches("input, select, textarea, video")) return;  // (a focused video has its own keys)
    const moves = { ArrowRight: [1, "delta"], ArrowLeft: [-1, "delta"], ArrowDown: [1, "sigma"], ArrowUp: [-1, "sigma"] };
    if (ev.key === " ") { ev.preventDefault(); setPlaying(!playing); }
    else if (moves[ev.key]) { ev.preventDefault(); setPlaying(false); step(...moves[ev.key]); }
  };
  document.addEventListener("keydown", keys);
  // The job's events while it may change (again after a resume or retry).
  let source = null;
  function follow() {
    if (source || ended(job.status)) return;
    source = new EventSource(`/api/jobs/${id}/events`);
    source.addEventListener("progress", async () => { try { refresh(await api(`/api/jobs/${id}`)); } catch { /* next event */ } });
    source.addEventListener("end", async () => { source.close(); source = null; refresh(await api(`/api/jobs/${id}`)); });
    source.addEventListener("deleted", () => { source.close(); source = null; if (live) jobMissing(`no job '${id}' (it was deleted)`); });
    source.onerror = () => { view.querySelector("#progress-text").textContent = progressText(job) + " (reconnecting…)"; };
  }
  follow();
  bandsFollow(job);
  view.querySelector("#actions").addEventListener("click", async (ev) => {
    const after = await runAction(ev, id);
    if (after === null) { location.hash = "#/jobs"; return; }
    if (after) { refresh(after); follow(); }
  });
  cleanup = () => { live = false; bands?.detach(); clearInterval(timer); document.removeEventListener("keydown", keys); source?.close(); video.pause();
    window.removeEventListener("resize", fit); if (frameCallback !== null) video.cancelVideoFrameCallback(frameCallback); };
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
  // The list holds summaries; each job's frames come from its own frames route.
  let jobs;
  try {
    jobs = (await api("/api/jobs?status=done&per_page=50")).jobs;
    const pages = await Promise.all(jobs.map((j) => api(`${j.frames_url}?per_page=1000`)));
    jobs.forEach((j, i) => { j.frames = pages[i].frames; });
  } catch (e) { view.querySelector("#pickers").replaceChildren(h(`<p class="error">${esc(e.message)}</p>`)); return; }
  if (!jobs.length) { view.querySelector("#pickers").replaceChildren(h(`<p class="muted">No finished jobs to compare yet.</p>`)); return; }
  const opts = jobs.flatMap((j) => j.frames.map((f) => `<option value="${j.id}:${f.index}">${esc(j.scene_name)} ${j.id.slice(0, 6)} — σ = ${sigmaOf(j, f)}, δ = ${deltaOf(j, f)}</option>`)).join("");
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

// Any band of a done job: σ and δ sliders over the whole band rule
// (σ ≥ 0, σ + δ ≤ π), the picture following them with certified frames
// from GET /api/jobs/{id}/band.png, and where the picture can change: the
// histogram of the roots' arguments (GET /api/jobs/{id}/arguments) with the
// band drawn over it, and the atlas laid out where those roots are (its
// cuts denser where the arguments are). app.js calls attach() on a job page.

const PI = Math.PI;
const STEPS = 720;  // slider positions over [0, π]: steps of π/720 (0.25°)

// An angle as a π fraction when it is one (denominator up to 36), else 4 digits.
export function angleLabel(v) {
  if (Math.abs(v) < 1e-12) return "0";
  for (let q = 1; q <= 36; q++) {
    const p = Math.round((v / PI) * q);
    if (p !== 0 && Math.abs(v - (p * PI) / q) < 1e-9) {
      const g = gcd(Math.abs(p), q), a = p / g, b = q / g;
      return `${a === 1 ? "" : a}π${b === 1 ? "" : "/" + b}`;
    }
  }
  return v.toFixed(4);
}
function gcd(a, b) { return b ? gcd(b, a % b) : a; }
function place(container, section, before) { if (before) before.before(section); else container.append(section); }

// The largest integer zoom that keeps the picture within `room` pixels (at least 1).
export function zoomFor(width, room = 720) { return Math.max(1, Math.floor(room / width)); }

export function attach(container, job, headers = () => ({}), before = null) {
  const section = document.createElement("section");
  section.className = "bands";
  section.id = "bands";
  if (job.status !== "done") {
    section.innerHTML = `<h2>Any band</h2><p class="muted">Every (σ, δ) of the band rule can be shown once the job is done.</p>`;
    place(container, section, before);
    return { section, detach() {} };
  }
  section.dataset.done = "yes";
  const zoom = zoomFor(job.width);
  section.innerHTML = `<h2>Any band</h2>
    <div class="band-view">
      <canvas id="band-canvas" width="${job.width}" height="${job.height}" aria-label="The band's picture"
        style="width:${job.width * zoom}px;height:${job.height * zoom}px"></canvas>
      <div class="band-side">
        <label class="slider">σ <input id="band-sigma" type="range" min="0" max="${STEPS}" value="0" aria-label="σ, start of the band"></label>
        <label class="slider">δ <input id="band-delta" type="range" min="0" max="${STEPS}" value="${STEPS / 18}" aria-label="δ, width of the band"></label>
        <p id="band-label"></p>
        <dl id="band-figures"></dl>
        <canvas id="band-arguments" width="360" height="120" aria-label="Arguments of the roots, with the band"></canvas>
        <p class="muted">Roots' |arg| over [0, π] (a grid of pixels, proven discs); the band is shaded. The picture changes only where σ or σ + δ crosses a root.</p>
      </div>
    </div>
    <div class="root-atlas">
      <h3>Atlas where the roots are
        <label class="muted">steps <input id="root-atlas-steps" type="number" min="1" max="12" value="6" style="width:3.5rem" aria-label="Steps of the atlas where the roots are"></label></h3>
      <p class="muted" id="root-atlas-cuts"></p>
      <div id="root-atlas" role="grid" aria-label="Bands cut where the roots are"></div>
    </div>`;
  place(container, section, before);
  const canvas = section.querySelector("#band-canvas"), ctx = canvas.getContext("2d");
  const sigma = section.querySelector("#band-sigma"), delta = section.querySelector("#band-delta");
  const hist = section.querySelector("#band-arguments"), hctx = hist.getContext("2d");
  let live = true, inFlight = false, wanted = null, shownKey = "", args = null;
  const shown = [];  // times (ms) at which a band was drawn, for the frame rate

  const value = (input) => (Number(input.value) / STEPS) * PI;
  function band() {
    // The band rule: δ at most π - σ (the δ slider is clamped as σ moves).
    const s = value(sigma);
    if (Number(delta.value) > STEPS - Number(sigma.value)) delta.value = String(STEPS - Number(sigma.value));
    return [s, value(delta)];
  }
  function drawArguments() {
    const [s, d] = band(), w = hist.width, hgt = hist.height;
    hctx.clearRect(0, 0, w, hgt);
    hctx.fillStyle = "rgba(224,160,80,.25)";
    hctx.fillRect((s / PI) * w, 0, Math.max(1, (d / PI) * w), hgt);
    if (args) {
      const max = Math.max(1, ...args.counts), bw = w / args.counts.length;
      hctx.fillStyle = "#9aa0aa";
      args.counts.forEach((c, i) => { const bh = c ? Math.max(1, (c / max) * (hgt - 14)) : 0; hctx.fillRect(i * bw, hgt - 12 - bh, Math.max(1, bw - 1), bh); });
    }
    hctx.fillStyle = "#e6e6e6"; hctx.font = "10px system-ui";
    ["0", "π/4", "π/2", "3π/4", "π"].forEach((t, i) => hctx.fillText(t, Math.min(w - 14, (i / 4) * w), hgt - 1));
  }
  async function request(s, d) {
    inFlight = true;
    const key = `${s}/${d}`;
    try {
      const r = await fetch(`/api/jobs/${job.id}/band.png?sigma=${s}&delta=${d}`, { headers: headers() });
      if (!live) return;
      if (!r.ok) {
        section.querySelector("#band-figures").innerHTML = `<dt>error</dt><dd class="error">${(await r.json()).detail}</dd>`;
      } else {
        const bitmap = await createImageBitmap(await r.blob());
        ctx.drawImage(bitmap, 0, 0);
        shownKey = key;
        canvas.dataset.band = key;
        const now = performance.now();
        shown.push(now);
        while (shown.length && now - shown[0] > 2000) shown.shift();
        const fps = shown.length > 1 ? (shown.length - 1) / ((now - shown[0]) / 1000) : 0;
        canvas.dataset.fps = fps.toFixed(1);
        const shares = JSON.parse(r.headers.get("X-Argand-Status-Shares") || "{}");
        section.querySelector("#band-figures").innerHTML =
          `<dt>certified</dt><dd>${(100 * Number(r.headers.get("X-Argand-Certified-Share"))).toFixed(3)}%</dd>`
          + Object.entries(shares).filter(([k]) => k !== "certified").map(([k, v]) => `<dt>${k}</dt><dd>${(100 * v).toFixed(3)}%</dd>`).join("")
          + `<dt>render</dt><dd>${(1000 * Number(r.headers.get("X-Argand-Render-Seconds"))).toFixed(0)} ms (${r.headers.get("X-Argand-Cache")})</dd>`
          + `<dt>frames/s</dt><dd id="band-fps">${fps.toFixed(1)}</dd>`;
      }
    } finally {
      inFlight = false;
      // Latest wins: while a band was on its way the sliders may have moved.
      if (live && wanted && `${wanted[0]}/${wanted[1]}` !== shownKey) { const [ws, wd] = wanted; wanted = null; request(ws, wd); }
    }
  }
  function update() {
    const [s, d] = band();
    section.querySelector("#band-label").innerHTML = `σ = ${angleLabel(s)}, δ = ${angleLabel(d)} <span class="muted">(band [${angleLabel(s)}, ${angleLabel(s + d)}])</span>`;
    drawArguments();
    if (inFlight) wanted = [s, d];
    else request(s, d);
  }
  // The atlas laid out where the roots are: its cuts from GET
  // /api/jobs/{id}/arguments?atlas=N (argand.frames.frame_set.atlas_cuts),
  // row i the bands starting at cut i, column j those ending j + 1 cuts
  // later, each a thumbnail of band.png (one request at a time); a click
  // shows that exact band above (the sliders move to the nearest step).
  const atlasBox = section.querySelector("#root-atlas"), stepsInput = section.querySelector("#root-atlas-steps");
  let atlasRun = 0;
  async function drawAtlas() {
    const run = ++atlasRun, steps = Math.max(1, Math.min(12, Number(stepsInput.value) || 6));
    const r = await fetch(`/api/jobs/${job.id}/arguments?atlas=${steps}`, { headers: headers() });
    if (!live || run !== atlasRun || !r.ok) return;
    const body = await r.json(), a = body.atlas;
    args = body;  // (the histogram comes with it)
    drawArguments();
    section.querySelector("#root-atlas-cuts").textContent = `Cuts: ${a.cuts.map(angleLabel).join(", ")} (denser where the roots' arguments are; ${a.bands.length} bands)`;
    atlasBox.innerHTML = "";
    atlasBox.style.gridTemplateColumns = `repeat(${steps}, auto)`;
    const cells = [];
    let k = 0;
    for (let i = 0; i < steps; i++) for (let j = 0; j < steps; j++) {
      const cell = document.createElement("button");
      cell.className = "root-atlas-cell";
      if (j < steps - i) {
        const [s, d] = a.bands[k++];
        cell.dataset.band = `${s}/${d}`;
        cell.title = `[${angleLabel(s)}, ${angleLabel(s + d)}]`;
        cell.innerHTML = `<img alt="band [${angleLabel(s)}, ${angleLabel(s + d)}]"><span>${angleLabel(s)} … ${angleLabel(s + d)}</span>`;
        cell.addEventListener("click", () => {
          sigma.value = String(Math.round((s / PI) * STEPS));
          delta.value = String(Math.min(STEPS - Number(sigma.value), Math.round((d / PI) * STEPS)));
          drawArguments();
          section.querySelector("#band-label").innerHTML = `σ = ${angleLabel(s)}, δ = ${angleLabel(d)} <span class="muted">(band [${angleLabel(s)}, ${angleLabel(s + d)}], a cut of the atlas)</span>`;
          if (inFlight) wanted = [s, d]; else request(s, d);
        });
        cells.push([cell, s, d]);
      } else {
        cell.disabled = true;
        cell.className += " empty";
      }
      atlasBox.append(cell);
    }
    for (const [cell, s, d] of cells) {  // one thumbnail at a time: the farm serves the sliders too
      if (!live || run !== atlasRun) return;
      const img = cell.querySelector("img");
      const t = await fetch(`/api/jobs/${job.id}/band.png?sigma=${s}&delta=${d}`, { headers: headers() });
      if (!t.ok) { cell.dataset.loaded = "error"; continue; }
      img.src = URL.createObjectURL(await t.blob());
      await img.decode().catch(() => {});
      cell.dataset.loaded = "yes";
    }
    atlasBox.dataset.done = String(steps);
  }
  stepsInput.addEventListener("change", drawAtlas);
  sigma.addEventListener("input", update);
  delta.addEventListener("input", update);
  update();
  drawAtlas();
  return { section, detach() { live = false; } };
}

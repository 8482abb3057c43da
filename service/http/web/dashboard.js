// The millsim dashboard: the studies with their progress, a study's results, plots, and each
// run's PSD and log tail; submit and cancel. Everything comes from the HTTP API
// (docs/openapi.yaml); data reaches the page only as text nodes, never as HTML.
"use strict";

const tokenInput = document.getElementById("token");
const main = document.getElementById("main");
const kStates = ["COMPLETE", "RUNNING", "CANCELING", "QUEUED", "EXECUTOR_ERROR", "SYSTEM_ERROR",
                 "CANCELED"];
let selectedRun = null;  // the run whose details are open on the study page
let refreshTimer = null;
let routeSerial = 0;  // the newest route(): an older one still waiting on the API draws nothing
let submitSection = null;  // built once, so a refresh keeps what is typed in it
// An error of the user's last action (e.g. a 401 on Cancel): shown on every refresh until it is
// dismissed or the user does something else (navigates, clicks a run, submits, types a token).
let notice = null;

tokenInput.value = sessionStorage.getItem("millsim-token") || "";
tokenInput.addEventListener("change", () => {
  notice = null;
  sessionStorage.setItem("millsim-token", tokenInput.value);
  route();
});

function headers() {
  return tokenInput.value ? { Authorization: "Bearer " + tokenInput.value } : {};
}

// A JSON request; rejects with the API's error message.
async function api(path, options = {}) {
  const response = await fetch(path, { ...options, headers: { ...headers(), ...(options.headers || {}) } });
  const type = response.headers.get("content-type") || "";
  const body = type.includes("json") ? await response.json() : await response.text();
  if (!response.ok) {
    const error = body && body.error ? body.error : { message: String(body) };
    const details = (error.details || []).map((d) => `${d.path} = ${d.value}: ${d.allowed}`);
    throw new Error([`HTTP ${response.status}: ${error.message}`, ...details].join("\n"));
  }
  return body;
}

// An element with attributes and children (strings become text nodes).
function el(tag, attributes = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attributes)) {
    if (key === "onclick") node.addEventListener("click", value);
    else node.setAttribute(key, value);
  }
  for (const child of children.flat())
    if (child !== null && child !== undefined)
      node.append(typeof child === "string" || typeof child === "number" ? String(child) : child);
  return node;
}

function number(x, digits = 3) {
  if (x === null || x === undefined) return "";
  if (x === 0) return "0";
  return Math.abs(x) >= 1e4 || Math.abs(x) < 1e-2 ? x.toExponential(digits - 1) : x.toPrecision(digits);
}

function micrometres(x) {
  return x === null || x === undefined ? "" : (x * 1e6).toFixed(1);
}

function progressBar(counts, total) {
  const bar = el("div", { class: "bar", title: kStates.filter((s) => counts[s]).map((s) => `${s} ${counts[s]}`).join(", ") });
  for (const s of kStates)
    if (counts[s]) {
      // Through the CSSOM: the page's policy refuses style attributes.
      const segment = el("span", { class: s });
      segment.style.width = `${(100 * counts[s]) / Math.max(1, total)}%`;
      bar.append(segment);
    }
  return bar;
}

function message(text, ok = false) {
  return el("div", { class: ok ? "message ok" : "message" }, text);
}

// The kept error, with a button that dismisses it.
function noticeBox() {
  const dismiss = el("button", { class: "dismiss", onclick: () => { notice = null; route(); } }, "Dismiss");
  return el("div", { id: "notice", class: "message" }, notice, " ", dismiss);
}

// An SVG plot from the API, fetched with the token so it works where reads need one.
async function plot(path, alt) {
  const response = await fetch(path, { headers: headers() });
  if (!response.ok) return el("p", { class: "state" }, `${alt}: not available yet`);
  const url = URL.createObjectURL(await response.blob());
  return el("img", { src: url, alt });
}

// Cancel after the user confirms it: a canceled study's runs are stopped and cannot be resumed.
async function cancel(id) {
  notice = null;
  if (!window.confirm(`Cancel study ${id}? Its queued runs will not start and its running runs are stopped.`)) {
    route();
    return;
  }
  try {
    await api(`/v1/studies/${encodeURIComponent(id)}/cancel`, { method: "POST", body: "{}" });
  } catch (e) {
    notice = `Cancel ${id}: ${e.message}`;
  }
  route();
}

function submitForm() {
  const text = el("textarea", { id: "study-text", placeholder: "a study file (JSON; docs/studies.md), pasted or loaded below" });
  const file = el("input", { type: "file", accept: ".json,application/json" });
  file.addEventListener("change", async () => {
    if (file.files.length) text.value = await file.files[0].text();
  });
  const result = el("div", { id: "submit-result" });
  const button = el("button", {
    id: "submit",
    onclick: async () => {
      result.replaceChildren();
      notice = null;
      try {
        const r = await api("/v1/studies", { method: "POST", headers: { "Content-Type": "application/json" }, body: text.value });
        result.append(message(`queued study ${r.study} with ${r.runs} runs`, true));
        location.hash = `#/studies/${r.study}`;
      } catch (e) {
        result.append(message(e.message));
      }
    },
  }, "Submit");
  return el("section", {}, el("h2", {}, "Submit a study"), text, el("div", {}, file, button), result);
}

// The studies list, as the children of #main.
async function studiesPage() {
  const list = await api("/v1/studies?limit=100");
  const rows = list.studies.map((s) => {
    const p = s.progress;
    const finished = p.finished;
    return el("tr", { class: "study", "data-id": s.id },
      el("td", {}, el("a", { href: `#/studies/${s.id}` }, s.id)),
      el("td", {}, s.name),
      el("td", {}, new Date(s.created_at * 1000).toLocaleString()),
      el("td", {}, progressBar(p.counts, p.total)),
      el("td", { class: "num" }, `${p.counts.COMPLETE || 0}/${p.total}`),
      el("td", { class: "state" }, s.canceled ? "canceled" : finished ? "finished" : "running"),
      el("td", {}, finished ? "" : el("button", { class: "cancel", onclick: () => cancel(s.id) }, "Cancel")));
  });
  return [
    el("h1", {}, "Studies"),
    rows.length
      ? el("table", { id: "studies" },
          el("tr", {}, ["study", "name", "created", "progress", "complete", "state", ""].map((h) => el("th", {}, h))),
          rows)
      : el("p", {}, "No study yet."),
    submitSection || (submitSection = submitForm())];
}

// A run's cumulative mass fraction (the mass finer than each class edge, outlet and dust) against
// particle diameter as a small inline SVG (log diameter axis).
function psdSvg(psd) {
  const ns = "http://www.w3.org/2000/svg";
  const svg = document.createElementNS(ns, "svg");
  svg.setAttribute("width", "380");
  svg.setAttribute("height", "230");
  svg.setAttribute("class", "psd");
  const edges = psd.edges_m, q = psd.cumulative_mass;
  const lo = Math.log10(edges[0]), hi = Math.log10(edges[edges.length - 1]);
  const x = (d) => 50 + (300 * (Math.log10(d) - lo)) / (hi - lo || 1);
  const y = (f) => 180 - 160 * f;
  const line = document.createElementNS(ns, "polyline");
  line.setAttribute("points", edges.map((d, k) => `${x(d).toFixed(1)},${y(q[k] || 0).toFixed(1)}`).join(" "));
  line.setAttribute("fill", "none");
  line.setAttribute("stroke", "#1e88e5");
  line.setAttribute("stroke-width", "2");
  const axis = document.createElementNS(ns, "path");
  axis.setAttribute("d", "M50,20 V180 H350");
  axis.setAttribute("stroke", "#555");
  axis.setAttribute("fill", "none");
  svg.append(axis, line);
  const label = (text, tx, ty, attributes = {}) => {
    const t = document.createElementNS(ns, "text");
    t.setAttribute("x", tx);
    t.setAttribute("y", ty);
    t.setAttribute("font-size", "11");
    for (const [key, value] of Object.entries(attributes)) t.setAttribute(key, value);
    t.textContent = text;
    svg.append(t);
  };
  label(`${(edges[0] * 1e6).toPrecision(2)} µm`, 50, 196);
  label(`${(edges[edges.length - 1] * 1e6).toPrecision(2)} µm`, 350, 196, { "text-anchor": "end" });
  label("1", 38, 24);
  label("0", 38, 180);
  // The axis titles: what is plotted, and in which unit.
  label("particle diameter (µm), log scale", 200, 220, { class: "x-title", "text-anchor": "middle" });
  label("cumulative mass fraction", 14, 100, { class: "y-title", "text-anchor": "middle", transform: "rotate(-90 14 100)" });
  return svg;
}

async function runDetails(runId) {
  const run = await api(`/v1/runs/${encodeURIComponent(runId)}`);
  const box = el("section", { id: "run-details" }, el("h2", {}, `Run ${run.id} (${run.state})`));
  box.append(el("p", {}, `parameters: ${JSON.stringify(run.params)}, attempts ${run.attempts}`));
  for (const a of run.attempt_history || [])
    if (a.resumed_from_s !== null) box.append(el("p", { class: "state" }, `attempt ${a.attempt} resumed from t = ${number(a.resumed_from_s)} s`));
  if (run.state === "COMPLETE") {
    try {
      const psd = await api(`/v1/runs/${encodeURIComponent(runId)}/psd`);
      const p = psd.outlet_psd;
      box.append(el("p", {}, `outlet PSD: d10 ${micrometres(p.d10_m)} µm, d50 ${micrometres(p.d50_m)} µm, d90 ${micrometres(p.d90_m)} µm`), psdSvg(p));
    } catch (e) {
      box.append(el("p", { class: "state" }, "no outlet PSD (the scene has no outlet or breakage)"));
    }
  }
  if (run.state === "COMPLETE")
    box.append(el("h2", {}, "Impact-energy spectrum"),
      await plot(`/v1/runs/${encodeURIComponent(runId)}/plot/impact-spectrum`, "impact-energy spectrum"));
  if (run.error) box.append(el("h2", {}, "Error"), el("pre", {}, run.error));
  box.append(el("h2", {}, "Log tail"), el("pre", { id: "log-tail" }, run.log_tail || "(empty)"));
  return box;
}

// A study's page (progress, results, plots, the selected run), as the children of #main.
async function studyPage(id) {
  const [study, results] = await Promise.all([
    api(`/v1/studies/${encodeURIComponent(id)}`),
    api(`/v1/studies/${encodeURIComponent(id)}/results`),
  ]);
  const p = study.progress;
  const header = el("div", {},
    el("h1", {}, `Study ${study.id}: ${study.name}`),
    el("p", {}, progressBar(p.counts, p.total),
      ` ${p.counts.COMPLETE || 0} of ${p.total} complete`,
      p.eta_s !== null && !p.finished ? `, about ${Math.round(p.eta_s)} s left` : "",
      study.canceled ? " (canceled)" : ""),
    p.finished ? null : el("button", { class: "cancel", onclick: () => cancel(study.id) }, "Cancel study"));
  const table = el("table", { id: "results" },
    el("tr", {}, ["run", "parameters", "state", "run s", "particle-steps/s", "d10 µm", "d50 µm", "d90 µm", `error (${results.error_metric})`]
      .map((h) => el("th", {}, h))));
  for (const r of results.runs) {
    const params = Object.entries(r.params).map(([k, v]) => `${k.split(".").pop()}=${v}`).join(", ");
    table.append(el("tr", {
      class: `clickable${r.run === selectedRun ? " selected" : ""}`,
      "data-run": r.run,
      onclick: () => { selectedRun = r.run; notice = null; route(); },
    },
      el("td", {}, r.run),
      el("td", {}, params + (r.reference ? " (ref)" : "")),
      el("td", {}, el("span", { class: "state" }, r.state)),
      el("td", { class: "num" }, number(r.run_time_s)),
      el("td", { class: "num" }, number(r.particle_steps_per_second)),
      el("td", { class: "num" }, micrometres(r.d10_m)),
      el("td", { class: "num" }, micrometres(r.d50_m)),
      el("td", { class: "num" }, micrometres(r.d90_m)),
      el("td", { class: "num" }, number(r.error, 4))));
  }
  const plots = el("div", { class: "plots" },
    await plot(`/v1/studies/${encodeURIComponent(id)}/plot/error-vs-time`, "error against run time"),
    await plot(`/v1/studies/${encodeURIComponent(id)}/plot/psd`, "outlet PSD of every run"));
  const details = selectedRun && selectedRun.startsWith(study.id + "-") ? await runDetails(selectedRun) : el("p", { class: "state" }, "Click a run for its PSD and log.");
  return [header, el("h2", {}, "Results"), table, el("h2", {}, "Plots"), plots, details];
}

// Draws the page the location asks for, then refreshes it every 3 s. Routes overlap (a refresh,
// a click, a typed token): one overtaken by a newer route while it waited on the API draws nothing
// and sets no timer, so a slow refresh of the list never lands on the study the user moved to.
async function route() {
  const serial = ++routeSerial;
  clearTimeout(refreshTimer);
  const match = location.hash.match(/^#\/studies\/(s[0-9]{6})$/);
  let children;
  try {
    children = match ? await studyPage(match[1]) : await studiesPage();
  } catch (e) {
    children = [message(e.message)];
  }
  if (serial !== routeSerial) return;
  main.replaceChildren(...children);
  if (notice) main.prepend(noticeBox());
  refreshTimer = setTimeout(route, 3000);
}

window.addEventListener("hashchange", () => { selectedRun = null; notice = null; route(); });
api("/v1/info").then((info) => {
  document.getElementById("server").textContent = `millsim ${info.millsim_version} · ${info.workers} workers`;
}).catch(() => {});
route();

// The viewer's pages: the runs and their scenarios (#/), one scenario (#/s/RUN/SCENARIO)
// with its replay, the agent's attempts, its variants and its files.
// window.viewer exposes what is on screen (clock, charts, players) for the browser tests.
"use strict";
const main = document.getElementById("main");
const crumb = document.getElementById("crumb");
window.viewer = { page: null };

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (key === "class") node.className = value;
    else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
    else if (key === "dataset") Object.assign(node.dataset, value);
    else node.setAttribute(key, value);
  }
  for (const child of children.flat()) if (child != null) node.append(child instanceof Node ? child : String(child));
  return node;
}

const badge = (text, kind) => el("span", { class: `badge ${kind || text}` }, text);
const fmt = (value, digits = 2) => (typeof value === "number" ? value.toFixed(digits) : value == null ? "" : String(value));

async function route() {
  if (window.viewer.clock) window.viewer.clock.pause();
  const hash = decodeURIComponent(location.hash.slice(1) || "/");
  try {
    if (hash.startsWith("/s/")) await showScenario(hash.slice(3));
    else await showRuns();
  } catch (err) {
    main.replaceChildren(el("p", { class: "note error" }, String(err)));
  }
}

// --- the runs ---------------------------------------------------------------------------------

async function showRuns() {
  const runs = await SW.api.runs();
  window.viewer = { page: "runs", runs };
  crumb.textContent = "";
  const search = el("input", { id: "search", type: "search", placeholder: "search scenario, class, code…" });
  const classes = [...new Set(runs.flatMap((r) => r.scenarios.map((s) => s.maneuver_class)).filter(Boolean))].sort();
  const classFilter = el("select", { id: "class-filter" }, el("option", { value: "" }, "every class"), classes.map((c) => el("option", { value: c }, c)));
  const statusFilter = el("select", { id: "status-filter" }, el("option", { value: "" }, "every status"),
    ["ok", "repaired", "fallback", "failed", "unjudged"].map((s) => el("option", { value: s }, s)));
  const verdictFilter = el("select", { id: "verdict-filter" }, el("option", { value: "" }, "every replay verdict"),
    ["passed", "failed", "played", "not played"].map((s) => el("option", { value: s }, s)));
  const list = el("div", { id: "runs" });
  const critical = criticalityFilters(runs);
  const sort = { field: null, dir: 1 };
  const render = () => {
    const words = search.value.toLowerCase().split(/\s+/).filter(Boolean);
    list.replaceChildren(...runs.map((run) => runCard(run, (s) =>
      (!classFilter.value || s.maneuver_class === classFilter.value)
      && (!statusFilter.value || s.status === statusFilter.value)
      && (!verdictFilter.value || s.verdict === verdictFilter.value)
      && critical.keep(s)
      && words.every((w) => [s.id, s.maneuver_class, s.status, s.verdict, ...s.codes].join(" ").toLowerCase().includes(w)),
    sort, (field) => { sort.dir = sort.field === field ? -sort.dir : 1; sort.field = field; render(); })));
  };
  for (const input of [search, classFilter, statusFilter, verdictFilter, ...critical.inputs]) input.addEventListener("input", render);
  main.replaceChildren(...[notPlayedBanner(runs), runs.length ? el("div", { class: "filters" }, search, classFilter, statusFilter, verdictFilter, ...critical.labels) : el("p", { class: "note" }, "No run found in the folders given."), list].filter(Boolean));
  render();
}

// How critical a mined record's event was (scenario_row's criticality): the list's columns,
// each sortable, and a bound per number ("TTC ≤ 2"); a bound drops scenarios without the number.
const CRITICALITY = [
  { field: "ttc_min_s", head: "TTC s", bound: "≤", title: "least time to collision (s)" },
  { field: "thw_min_s", head: "THW s", bound: "≤", title: "least time headway (s)" },
  { field: "brake_1s_max_ms2", head: "brake m/s²", bound: "≥", title: "hardest 1 s of braking (m/s²)" },
  { field: "lat_acc_peak_ms2", head: "lat m/s²", bound: "≥", title: "peak lateral acceleration (m/s²)" },
];

function criticalityFilters(runs) {
  if (!runs.some((r) => r.scenarios.some((s) => s.criticality))) return { inputs: [], labels: [], keep: () => true };
  const inputs = CRITICALITY.map((c) => el("input", { id: `crit-${c.field}`, class: "bound", type: "number", step: "any", min: "0",
    placeholder: "any", title: `${c.title}: keep ${c.bound} this` }));
  const labels = CRITICALITY.map((c, i) => el("label", { class: "bound" }, `${c.head.split(" ")[0]} ${c.bound} `, inputs[i]));
  const keep = (s) => CRITICALITY.every((c, i) => {
    if (inputs[i].value === "") return true;
    const value = s.criticality && s.criticality[c.field];
    const bound = Number(inputs[i].value);
    return typeof value === "number" && (c.bound === "≤" ? value <= bound : value >= bound);
  });
  return { inputs, labels, keep };
}

// scenarios in the order the clicked criticality column says (no value last, either way)
function sortedBy(scenarios, sort) {
  if (!sort || !sort.field) return scenarios;
  const value = (s) => (s.criticality && typeof s.criticality[sort.field] === "number" ? s.criticality[sort.field] : null);
  return [...scenarios].sort((a, b) => (value(a) === null) - (value(b) === null) || sort.dir * (value(a) - value(b)));
}

// One banner over the runs when scenarios were delivered without being played in esmini
// (summary.json's replay.not_played): their "ok" was never checked against the record.
function notPlayedBanner(runs) {
  const unplayed = runs.filter((r) => r.replay && r.replay.not_played);
  if (!unplayed.length) return null;
  const reason = (r) => String(r.replay.not_played_because || "unknown").split(" (")[0];
  return el("div", { class: "banner", id: "not-played-banner", role: "alert" },
    el("strong", {}, "Replay not run."),
    unplayed.map((r) => el("div", { class: "not-played-run", dataset: { run: r.run } },
      `${r.replay.not_played} scenarios of ${r.run} were never played in esmini (${reason(r)}): validated, but not checked against the record.`)),
    el("div", {}, "scenweave doctor says how to get the player; scenweave replay RUN_DIR then plays them."));
}

function runCard(run, keep, sort, onSort) {
  const shown = sortedBy(run.scenarios.filter(keep), sort);
  const critical = run.scenarios.some((s) => s.criticality);
  const counts = run.counts ? Object.entries(run.counts).map(([k, v]) => `${v} ${k}`).join(", ") : "";
  const replay = !run.replay ? "" : run.replay.not_played && !run.replay.played ? "replay: not run"
    : `replay: ${run.replay.passed}/${run.replay.played} played as recorded`
      + (run.replay.not_played ? `, ${run.replay.not_played} not played` : "");
  const links = [];
  if (run.report && !SW.api.isStatic()) links.push(el("a", { href: `run/${encodeURIComponent(run.run)}/report.html`, target: "_blank" }, "report.html"));
  if (run.mining_report && !SW.api.isStatic()) links.push(el("a", { href: `mining/${encodeURIComponent(run.run)}`, target: "_blank" }, "mining report"));
  const rows = shown.map((s) => el("tr", { class: "scenario", dataset: { key: s.key }, onclick: () => { location.hash = "#/s/" + s.key; } },
    el("td", {}, el("a", { href: "#/s/" + s.key }, s.id), s.in_situ ? [" ", inSituLink(s.in_situ)] : null),
    el("td", {}, s.maneuver_class || ""),
    el("td", {}, badge(s.status)),
    el("td", {}, s.attempts == null ? "" : s.attempts),
    el("td", {}, badge(s.verdict, s.verdict), " ", s.codes.join(", ")),
    el("td", {}, s.worst.map((w) => `${w.quantity}: max ${fmt(w.max)}${w.rms != null ? `, rms ${fmt(w.rms)}` : ""}`).join("; ")),
    el("td", {}, s.variants || ""),
    critical ? CRITICALITY.map((c) => el("td", { class: "num", dataset: { field: c.field } }, s.criticality ? fmt(s.criticality[c.field]) : "")) : null));
  const heads = ["scenario", "class", "status", "attempts", "replay", "worst series errors", "variants"].map((h) => el("th", {}, h));
  if (critical) heads.push(...CRITICALITY.map((c) => el("th", { class: "sortable", title: `${c.title}; click to sort`, dataset: { sort: c.field },
    onclick: () => onSort(c.field) }, c.head, sort && sort.field === c.field ? (sort.dir > 0 ? " ▲" : " ▼") : "")));
  return el("section", { class: "run", dataset: { run: run.run } },
    el("h2", {}, run.run),
    el("div", { class: "facts" }, [run.mode, run.map, counts, replay].filter(Boolean).join(" · "), " ", ...links.flatMap((a) => [a, " "])),
    el("table", {}, el("thead", {}, el("tr", {}, heads)),
      el("tbody", {}, rows)),
    shown.length ? null : el("p", { class: "note" }, "no scenario matches"));
}

// the link to a scenario's in-situ scene, with how closely its recorded traffic played
function inSituLink(inSitu) {
  const share = inSitu.share == null ? "" : ` ${fmt(100 * inSitu.share, 1)} % ≤ 0.1 m`;
  return el("a", { class: `in-situ-link badge ${inSitu.passed === false ? "failed" : inSitu.passed ? "passed" : ""}`, href: "#/s/" + inSitu.key,
    onclick: (e) => e.stopPropagation(), title: "the event on its recorded road with every recorded vehicle" },
  `in situ${inSitu.vehicles ? ` · ${inSitu.vehicles} vehicles` : ""}${share}`);
}

// --- one scenario -----------------------------------------------------------------------------

async function showScenario(key) {
  const detail = await SW.api.scenario(key);
  const scene = detail.scene;
  crumb.textContent = key;
  const status = detail.status || {};
  const passed = scene.in_situ ? scene.in_situ.passed !== false : !scene.findings.length;
  const head = el("div", { class: "facts" },
    el("strong", {}, scene.scenario_id), " · ", scene.maneuver_class || "?", " · ", scene.domain || "", " · ",
    scene.in_situ ? null : [badge(status.status || "unjudged"), " "],
    scene.played ? badge(passed ? "replay passed" : "replay failed", passed ? "passed" : "failed") : badge("not played"),
    detail.variant ? el("span", {}, " · variant: ", variantFacts(detail.variant)) : null,
    scene.in_situ ? el("span", { id: "in-situ-facts" }, " · ", inSituFacts(scene.in_situ)) : null,
    detail.in_situ ? [" · ", inSituLink(detail.in_situ)] : null);
  const body = el("div", { id: "tab-body" });
  const tabs = { replay: () => replayTab(body, detail), trace: () => traceTab(body, detail), variants: () => variantsTab(body, detail), files: () => filesTab(body, detail) };
  const bar = el("div", { class: "tabs" }, Object.keys(tabs).map((name) => el("button", {
    id: `tab-${name}`, dataset: { tab: name },
    onclick: (e) => { bar.querySelectorAll("button").forEach((b) => b.classList.remove("active")); e.target.classList.add("active"); if (window.viewer.clock) window.viewer.clock.pause(); tabs[name](); },
  }, name === "trace" ? `trace (${detail.attempts.length} attempt${detail.attempts.length === 1 ? "" : "s"})` : name === "variants" ? `variants (${detail.variants.length})` : name)));
  main.replaceChildren(head, bar, body);
  window.viewer = { page: "scenario", key, detail };
  bar.querySelector("button").classList.add("active");
  tabs.replay();
}

// what was chosen and how closely the recorded traffic played (the in-situ judge's numbers)
function inSituFacts(inSitu) {
  const choice = inSitu.choice || {}, overall = (inSitu.judge || {}).overall || {};
  const position = overall.position || {}, heading = overall.heading || {};
  const window_ = choice.window_s ? `window ${fmt(choice.window_s[0], 1)}–${fmt(choice.window_s[1], 1)} s` : null;
  return [choice.vehicles != null ? `${choice.vehicles} vehicles` : null, window_,
    position.share != null ? `within 0.1 m: ${fmt(100 * position.share, 2)} % of ${overall.samples} samples` : "not judged",
    position.worst_m != null ? `worst ${fmt(position.worst_m, 3)} m${position.worst_of ? ` (${position.worst_of} at ${fmt(position.worst_at_s)} s)` : ""}` : null,
    heading.share != null ? `heading within 0.05 rad: ${fmt(100 * heading.share, 2)} %` : null].filter(Boolean).join(" · ");
}

// the in-situ judge's numbers per vehicle; clicking a row seeks to its worst sample
function inSituTable(inSitu, clock) {
  const vehicles = Object.entries((inSitu.judge || {}).vehicles || {});
  if (!vehicles.length) return null;
  vehicles.sort(([, a], [, b]) => (b.position.worst_m || 0) - (a.position.worst_m || 0));
  return el("details", { id: "in-situ-table" }, el("summary", {}, `per vehicle (${vehicles.length}), worst first`),
    el("table", {}, el("thead", {}, el("tr", {}, ["vehicle", "samples", "≤ 0.1 m", "worst (m)", "at (s)", "heading ≤ 0.05 rad", "speed ≤ 0.1 m/s"].map((h) => el("th", {}, h)))),
      el("tbody", {}, vehicles.map(([name, fit]) => el("tr", { dataset: { vehicle: name }, onclick: () => fit.position.worst_at_s != null && clock.seek(fit.position.worst_at_s) },
        el("td", {}, name), el("td", {}, fit.samples), el("td", {}, `${fmt(100 * fit.position.share, 1)} %`),
        el("td", {}, fmt(fit.position.worst_m, 3)), el("td", {}, fmt(fit.position.worst_at_s)),
        el("td", {}, `${fmt(100 * fit.heading.share, 1)} %`), el("td", {}, `${fmt(100 * fit.speed.share, 1)} %`))))));
}

function replayTab(body, detail) {
  const scene = detail.scene;
  if (!scene.played) {
    body.replaceChildren(el("p", { class: "note", id: "not-played" }, scene.problem || "not played"), scene.log ? el("pre", {}, scene.log.join("\n")) : null);
    return;
  }
  const clock = new Clock(scene.duration_s);
  const canvas = el("canvas", { class: "scene", id: "scene" });
  const play = el("button", { id: "play" }, "▶ play");
  const scrub = el("input", { id: "scrub", type: "range", min: 0, max: scene.duration_s, step: 0.01, value: 0 });
  const rate = el("select", { id: "rate" }, [0.25, 0.5, 1, 2, 4, 8].map((r) => el("option", { value: r, ...(r === 1 ? { selected: "" } : {}) }, `×${r}`)));
  const camera = el("select", { id: "camera" }, el("option", { value: "follow" }, "follow the ego"), el("option", { value: "whole" }, "whole scene"));
  const time = el("span", { id: "clock" }, "0.00 s");
  const timeline = el("div", { class: "timeline", id: "timeline" });
  const player = new Player(canvas, scene, { camera: "follow" });
  const findings = scene.findings.filter((f) => f.t != null);
  for (const f of findings) {
    timeline.append(el("div", { class: "mark", title: `${f.code} at ${fmt(f.t)} s`, style: `left: ${100 * f.t / scene.duration_s}%`, onclick: () => clock.seek(f.t) }));
  }
  const list = el("ul", { class: "findings", id: "findings" },
    scene.findings.length ? scene.findings.map((f) => el("li", { dataset: { code: f.code, t: f.t == null ? "" : f.t }, onclick: () => f.t != null && clock.seek(f.t) },
      f.t == null ? "" : `${fmt(f.t)} s · `, el("strong", {}, f.code), " ", f.message.replace(/^at [\d.]+ s: /, "")))
      : el("li", { class: "pass" }, scene.in_situ ? "every vehicle as recorded: no IN_SITU_* finding" : "replay as recorded: no REPLAY_* finding"));
  const named = Object.entries(player.colours);
  const legend = el("div", { class: "legend" }, named.length <= 8 ? named.map(([n, c]) => el("span", { style: `color:${c}` }, `■ ${n}`))
    : [el("span", { style: `color:${player.colours[EGO]}` }, `■ ${EGO}`), el("span", {}, `■ ${named.length - 1} recorded vehicles`)]);
  const stage = el("div", { class: "stage" }, canvas, el("div", { class: "controls" }, play, time, rate, camera, legend), scrub, timeline, list,
    scene.in_situ ? inSituTable(scene.in_situ, clock) : null);
  const charts = el("div", { class: "charts", id: "charts" });
  body.replaceChildren(el("div", { class: "replay" }, stage, charts));
  const made = [speedChart(charts, scene, clock, player.colours, findings), gapChart(charts, scene, clock, player.colours, findings),
    stopLineChart(charts, scene, clock, player.colours, findings), lateralChart(charts, scene, clock, player.colours, findings),
    lightStrip(charts, scene, clock)].filter(Boolean);
  clock.on((t) => {
    player.t = t;
    player.draw();
    scrub.value = t;
    time.textContent = `${t.toFixed(2)} s`;
    play.textContent = clock.playing ? "❚❚ pause" : "▶ play";
    list.querySelectorAll("li[data-t]").forEach((li) => li.classList.toggle("active", li.dataset.t !== "" && Math.abs(Number(li.dataset.t) - t) < 0.25));
  });
  play.addEventListener("click", () => (clock.playing ? clock.pause() : clock.play()));
  scrub.addEventListener("input", () => { clock.pause(); clock.seek(Number(scrub.value)); });
  rate.addEventListener("change", () => { clock.rate = Number(rate.value); });
  camera.addEventListener("change", () => { player.camera = camera.value; player.draw(); });
  window.addEventListener("resize", () => player.draw());
  Object.assign(window.viewer, { clock, player, charts: Object.fromEntries(made.map((c) => [c.name, c])) });
  clock.seek(0);
}

function diffBlock(text) {
  return el("pre", { class: "diff" }, (text || "").split("\n").map((line) =>
    el("span", { class: line.startsWith("+") && !line.startsWith("+++") ? "add" : line.startsWith("-") && !line.startsWith("---") ? "del" : "" }, line + "\n")));
}

function folded(title, content, open = false) {
  if (content == null || content === "") return null;
  const text = typeof content === "string" ? content : JSON.stringify(content, null, 1);
  return el("details", open ? { open: "" } : {}, el("summary", {}, title), content instanceof Node ? content : el("pre", {}, text));
}

function traceTab(body, detail) {
  if (!detail.attempts.length) {
    body.replaceChildren(el("p", { class: "note" }, "No trace: this folder has no trace.jsonl with an attempt."));
    return;
  }
  body.replaceChildren(el("div", { id: "attempts" }, detail.attempts.map((a, i) => {
    const make = a.make || {}, run = a.execute || {}, check = a.validate || {};
    const good = check.valid === true;
    const prompt = make.prompt && typeof make.prompt === "object" ? Object.entries(make.prompt).map(([k, v]) => `### ${k}\n${v}`).join("\n\n") : make.prompt;
    const replay = check.replay || {};
    const findings = (check.errors || []).map((e) => `${e.code}: ${e.message || ""}`).join("\n");
    return el("section", { class: `attempt ${good ? "good" : "bad"}`, dataset: { attempt: i + 1 } },
      el("h3", {}, `attempt ${a.number || i + 1} · ${a.made_by}${make.strategy ? ` (${make.strategy})` : ""} · `, badge(good ? "valid" : "failed", good ? "passed" : "failed"),
        check.replay ? [" ", badge(replay.passed ? "replay passed" : "replay failed", replay.passed ? "passed" : "failed")] : null),
      el("div", { class: "facts" }, [
        make.tokens_in != null ? `tokens in ${make.tokens_in}, out ${make.tokens_out}` : null,
        make.llm_latency_s != null ? `LLM ${fmt(make.llm_latency_s)} s` : null,
        make.duration_s != null ? `${a.made_by} ${fmt(make.duration_s)} s` : null,
        run.duration_s != null ? `sandbox ${fmt(run.duration_s)} s` : null,
        check.duration_s != null ? `validation ${fmt(check.duration_s)} s` : null,
        run.taxonomy || check.taxonomy ? `error: ${run.taxonomy || check.taxonomy}` : null].filter(Boolean).join(" · ")),
      folded("prompt", prompt), folded("reply", make.reply), folded("extracted code", make.code),
      make.diff ? folded("diff to the worked example", diffBlock(make.diff)) : null,
      folded("sandbox result", run.error || run.sandbox ? { error: run.error, sandbox: run.sandbox } : null, !good && !!run.error),
      folded("validation and replay findings", findings || (check.valid ? "valid, no finding" : ""), !good && !!findings),
      check.replay ? folded("replay", replay) : null);
  })));
}

function variantsTab(body, detail) {
  const entries = [{ name: "record (delivered)", key: detail.key, scene: detail.scene }, ...detail.variants.map((v) => ({ name: v.name, key: v.key, variant: v.variant }))];
  if (entries.length === 1) {
    body.replaceChildren(el("p", { class: "note" }, "No variant of this record (scenweave run --vary N)."));
    return;
  }
  const grid = el("div", { class: "variants", id: "variants" });
  const play = el("button", { id: "play-variants" }, "▶ play all");
  body.replaceChildren(play, grid);
  const players = [];
  const clock = new Clock(Math.max(...[detail.scene.duration_s || 0]));
  clock.on((t) => players.forEach((p) => { p.t = Math.min(t, p.scene.duration_s); p.draw(); }));
  play.addEventListener("click", () => (clock.playing ? clock.pause() : clock.play()));
  window.viewer.clock = clock;
  entries.forEach(async (entry) => {
    const canvas = el("canvas", { class: "scene" });
    const v = entry.variant || {};
    const card = el("div", { class: "stage", dataset: { variant: entry.name } }, el("h3", {}, el("a", { href: "#/s/" + entry.key }, entry.name)),
      el("div", { class: "facts" }, entry.variant ? variantFacts(v) : "what the record became"), canvas);
    grid.append(card);
    const scene = entry.scene || (await SW.api.scenario(entry.key)).scene;
    if (!scene.played) { canvas.replaceWith(el("p", { class: "note" }, scene.problem || "not played")); return; }
    clock.duration = Math.max(clock.duration, scene.duration_s);
    const player = new Player(canvas, scene, { camera: "follow" });
    players.push(player);
    player.draw();
  });
}

// what a variant changed (variant.json), whether it was kept, and why not
function variantFacts(v) {
  const changed = (v.changed || []).map((c) => (typeof c === "string" ? c : JSON.stringify(c))).join(", ");
  return [v.kept ? "kept" : "not kept", v.aspect, changed && `changed: ${changed}`, (v.errors || [])[0]].filter(Boolean).join(" · ");
}

function filesTab(body, detail) {
  const view = el("pre", { id: "file-view" }, "choose a file");
  const list = el("ul", {}, detail.files.map((f) => el("li", {}, el("a", { dataset: { file: f.name }, onclick: async () => { view.textContent = await SW.api.file(detail.key, f.name); } }, f.name), ` ${f.bytes} B`)));
  body.replaceChildren(el("div", { class: "files" }, list, view));
}

window.addEventListener("hashchange", route);
route();

// Charts on the replay's clock (uPlot): speed, gap, lateral offset and lane, light state.
// Each shows the replay's series, the record's values with the judge's tolerance (error
// bars; a band around a mined record's own series), the REPLAY_* findings at their times
// and a line at the clock's time. Clicking a chart seeks there.
"use strict";

function resampled(times, fromT, values) {
  return times.map((t) => interpolate(fromT, values, t));
}

function markPlugin(chart) {
  // draws: tolerance bands, record marks with error bars, findings, the clock's time
  return {
    hooks: {
      draw: [(u) => {
        const ctx = u.ctx, dpr = uPlot.pxRatio;
        ctx.save();
        for (const band of chart.bands || []) {
          ctx.fillStyle = band.colour + "33";
          ctx.beginPath();
          let started = false;
          const upper = [], lower = [];
          band.t.forEach((t, i) => {
            if (band.values[i] == null || t == null) return;
            upper.push([u.valToPos(t, "x", true), u.valToPos(band.values[i] + band.tol, "y", true)]);
            lower.push([u.valToPos(t, "x", true), u.valToPos(band.values[i] - band.tol, "y", true)]);
          });
          upper.concat(lower.reverse()).forEach(([x, y]) => { if (started) ctx.lineTo(x, y); else { ctx.moveTo(x, y); started = true; } });
          ctx.closePath();
          ctx.fill();
        }
        for (const mark of chart.marks || []) {
          const x = u.valToPos(mark.t, "x", true);
          const y = u.valToPos(mark.value, "y", true);
          const y0 = u.valToPos(mark.value - mark.tol, "y", true), y1 = u.valToPos(mark.value + mark.tol, "y", true);
          ctx.strokeStyle = mark.colour;
          ctx.lineWidth = 1.5 * dpr;
          ctx.beginPath(); ctx.moveTo(x, y0); ctx.lineTo(x, y1);
          ctx.moveTo(x - 4 * dpr, y0); ctx.lineTo(x + 4 * dpr, y0); ctx.moveTo(x - 4 * dpr, y1); ctx.lineTo(x + 4 * dpr, y1);
          ctx.stroke();
          ctx.fillStyle = "white";
          ctx.beginPath();
          ctx.moveTo(x, y - 5 * dpr); ctx.lineTo(x + 5 * dpr, y); ctx.lineTo(x, y + 5 * dpr); ctx.lineTo(x - 5 * dpr, y); ctx.closePath();
          ctx.fill(); ctx.stroke();
        }
        const top = u.bbox.top, bottom = u.bbox.top + u.bbox.height;
        ctx.font = `${10 * dpr}px system-ui, sans-serif`;
        for (const finding of chart.findings || []) {
          const x = u.valToPos(finding.t, "x", true);
          ctx.strokeStyle = "#cf222e";
          ctx.setLineDash([4 * dpr, 3 * dpr]);
          ctx.beginPath(); ctx.moveTo(x, top); ctx.lineTo(x, bottom); ctx.stroke();
          ctx.setLineDash([]);
          ctx.fillStyle = "#cf222e";
          ctx.fillText(finding.code, x + 3 * dpr, top + 10 * dpr);
        }
        const x = u.valToPos(chart.clock.t, "x", true);
        ctx.strokeStyle = "#1f2328";
        ctx.lineWidth = 1.5 * dpr;
        ctx.beginPath(); ctx.moveTo(x, top); ctx.lineTo(x, bottom); ctx.stroke();
        ctx.restore();
      }],
    },
  };
}

function makeChart(holder, title, spec, clock) {
  const box = document.createElement("div");
  box.className = "chart";
  box.dataset.chart = spec.name;
  box.innerHTML = `<h3>${title}</h3>`;
  holder.appendChild(box);
  const chart = { name: spec.name, clock, marks: spec.marks, bands: spec.bands, findings: spec.findings, data: spec.data, labels: spec.series.map((s) => s.label) };
  const options = {
    width: Math.max(360, holder.clientWidth - 12), height: spec.height || 170,
    legend: { show: true },
    cursor: { drag: { x: false, y: false } },
    scales: { x: { time: false, range: [0, clock.duration] }, ...(spec.scales || {}) },
    axes: [{ label: "time (s)", size: 36 }, { label: spec.unit, size: 52 }, ...(spec.axes || [])],
    series: [{ label: "t (s)" }, ...spec.series],
    plugins: [markPlugin(chart)],
  };
  chart.plot = new uPlot(options, spec.data, box);
  chart.plot.over.addEventListener("click", (e) => clock.seek(chart.plot.posToVal(e.offsetX, "x")));
  clock.on(() => chart.plot.redraw(false, false));
  return chart;
}

function speedChart(holder, scene, clock, colours, findings) {
  const c = scene.charts.speed;
  const names = Object.keys(c.series);
  const data = [scene.times, ...names.map((n) => c.series[n])];
  // the ego's line is drawn first and wider: another car at the same speed would hide it
  const series = names.map((n) => ({ label: n, stroke: colours[n], width: n === EGO ? 4 : 1.6 }));
  const bands = [];
  for (const [name, values] of Object.entries(c.recorded || {})) {
    data.push(resampled(scene.times, c.recorded_t, values));
    series.push({ label: `${name} recorded`, stroke: colours[name], dash: [6, 4], width: 1.2 });
    bands.push({ t: c.recorded_t, values, tol: c.series_tol || c.tol, colour: colours[name] });
  }
  const marks = c.marks.map((m) => ({ ...m, colour: colours[m.entity] || "#555" }));
  return makeChart(holder, `speed (m/s)` + (c.tol == null ? "" : ` — record: ◇ with ±${c.tol} m/s, the judge's tolerance`),
    { name: "speed", unit: "m/s", data, series, marks, bands, findings }, clock);
}

function gapChart(holder, scene, clock, colours, findings) {
  const c = scene.charts.gap;
  if (!c || !c.times) return null;
  const names = Object.keys(c.series);
  const data = [c.times, ...names.map((n) => c.series[n])];
  const series = names.map((n) => ({ label: `${n} gap`, stroke: colours[n], width: 1.6, spanGaps: false }));
  const bands = [];
  if (c.recorded && c.recorded_t) {
    data.push(resampled(c.times, c.recorded_t, c.recorded));
    series.push({ label: "npc recorded", stroke: colours.npc || "#555", dash: [6, 4], width: 1.2 });
    bands.push({ t: c.recorded_t, values: c.recorded, tol: c.series_tol || c.tol, colour: colours.npc || "#555" });
  }
  const marks = c.marks.map((m) => ({ ...m, colour: colours[m.entity] || "#555" }));
  return makeChart(holder, `gap to the ego along its lane (m)` + (c.tol == null ? "" : ` — record: ◇ ±${c.tol} m`),
    { name: "gap", unit: "m", data, series, marks, bands, findings }, clock);
}

function lateralChart(holder, scene, clock, colours, findings) {
  const c = scene.charts.lateral;
  const names = Object.keys(c.offset);
  const data = [scene.times, ...names.map((n) => c.offset[n]), ...names.map((n) => c.lane[n])];
  const series = [
    ...names.map((n) => ({ label: `${n} offset`, stroke: colours[n], width: 1.6 })),
    ...names.map((n) => ({ label: `${n} lane`, stroke: colours[n], width: 1, dash: [2, 3], scale: "lane", paths: uPlot.paths.stepped({ align: 1 }) })),
  ];
  for (const [name, values] of Object.entries(c.recorded || {})) {  // a mined record's own
    data.push(resampled(scene.times, c.recorded_t, values));
    series.push({ label: `${name} recorded offset`, stroke: colours[name], dash: [6, 4], width: 1.2 });
  }
  return makeChart(holder, "offset from the lane centre (m, solid; recorded: dashed) and lane id (dotted)",
    { name: "lateral", unit: "m", data, series, findings,
      scales: { y: { range: (u, min, max) => [Math.min(min, -2), Math.max(max, 2)] }, lane: {} }, axes: [{ scale: "lane", side: 1, label: "lane", size: 40, grid: { show: false } }] }, clock);
}

function lightStrip(holder, scene, clock) {
  if (!scene.lights.length) return null;
  const box = document.createElement("div");
  box.className = "chart";
  box.dataset.chart = "light";
  box.innerHTML = "<h3>traffic light</h3>";
  const strip = document.createElement("div");
  strip.className = "lightstrip";
  for (const [from, to, colour] of scene.lights[0].spans) {
    const span = document.createElement("div");
    span.className = "span";
    span.dataset.colour = colour;
    span.style.left = (100 * from / clock.duration) + "%";
    span.style.width = (100 * (to - from) / clock.duration) + "%";
    span.style.background = LIGHT_COLOURS[colour] || "#999";
    span.title = `${colour} ${from.toFixed(2)}–${to.toFixed(2)} s`;
    strip.appendChild(span);
  }
  const cursor = document.createElement("div");
  cursor.className = "cursor";
  strip.appendChild(cursor);
  box.appendChild(strip);
  holder.appendChild(box);
  strip.addEventListener("click", (e) => clock.seek(e.offsetX / strip.clientWidth * clock.duration));
  const move = (t) => { cursor.style.left = (100 * t / clock.duration) + "%"; };
  clock.on(move);
  move(clock.t);
  return { name: "light", box };
}

function stopLineChart(holder, scene, clock, colours, findings) {
  const c = scene.charts.stop_line;
  if (!c || !c.distance) return null;
  const line = scene.times.map(() => c.line_m);
  return makeChart(holder, `distance the ego drove (m) against the record's stop line (${c.line_m.toFixed(1)} m)`,
    { name: "stop_line", unit: "m", data: [scene.times, c.distance, line],
      series: [{ label: "ego driven", stroke: colours[EGO], width: 1.6 }, { label: "stop line", stroke: "#1f2328", dash: [6, 4], width: 1.2 }], findings }, clock);
}

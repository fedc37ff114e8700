// The bird's-eye replay: lanes from the map, every actor as an oriented box to scale, the
// lights in their colour, the record's ghost where it has a series, on one clock shared with
// the charts. World frame: OpenDRIVE's (x east, y north, heading counter-clockwise).
"use strict";
const EGO = "hero";
const EGO_COLOUR = "#1f4e9c";
const OTHER_COLOURS = ["#e07b00", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf"];
// the following camera frames the actors this close to the ego, at least FOLLOW_MIN_M across
const FOLLOW_NEAR_M = 80;
const FOLLOW_MIN_M = 60;
const LIGHT_COLOURS = { green: "#2ca02c", yellow: "#f2c200", red: "#d62728", off: "#555" };

function actorColours(names) {
  const colours = {};
  names.filter((n) => n !== EGO).forEach((n, i) => { colours[n] = OTHER_COLOURS[i % OTHER_COLOURS.length]; });
  colours[EGO] = EGO_COLOUR;
  return colours;
}

// The sample index at or before t, and how far t lies towards the next one.
function sampleAt(times, t) {
  let lo = 0, hi = times.length - 1;
  if (t <= times[0]) return [0, 0];
  if (t >= times[hi]) return [hi, 0];
  while (hi - lo > 1) { const mid = (lo + hi) >> 1; if (times[mid] <= t) lo = mid; else hi = mid; }
  return [lo, (t - times[lo]) / (times[lo + 1] - times[lo] || 1)];
}

function lerp(series, i, w) {
  return i + 1 < series.length ? series[i] + (series[i + 1] - series[i]) * w : series[i];
}

function lerpAngle(series, i, w) {
  if (i + 1 >= series.length) return series[i];
  let d = series[i + 1] - series[i];
  d = Math.atan2(Math.sin(d), Math.cos(d));
  return series[i] + d * w;
}

function interpolate(times, values, t) {
  if (!times || !values || !times.length) return null;
  if (t < times[0] || t > times[times.length - 1]) return null;
  const [i, w] = sampleAt(times, t);
  const a = values[i], b = values[Math.min(i + 1, values.length - 1)];
  if (a == null || b == null) return a == null ? b : a;
  return a + (b - a) * w;
}

class Player {
  constructor(canvas, scene, options = {}) {
    this.canvas = canvas;
    this.scene = scene;
    this.camera = options.camera || "follow";
    this.colours = actorColours(Object.keys(scene.actors));
    this.label = options.label || "";
    this.t = 0;
    this.bounds = this.sceneBounds();
  }

  // Whether an actor is on the road at t: always, unless it has a recorded span (in-situ
  // scenes: a car waits parked off the road before its track starts and after it ends).
  onRoad(name, t) {
    const span = this.scene.actors[name].span;
    return !span || (t >= span[0] - 1e-6 && t <= span[1] + 1e-6);
  }

  sceneBounds() {
    let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    for (const [name, actor] of Object.entries(this.scene.actors)) {
      actor.x.forEach((x, i) => {
        if (!this.onRoad(name, this.scene.times[i])) return;
        x0 = Math.min(x0, x); x1 = Math.max(x1, x);
        y0 = Math.min(y0, actor.y[i]); y1 = Math.max(y1, actor.y[i]);
      });
    }
    for (const light of this.scene.lights) {
      x0 = Math.min(x0, light.x); x1 = Math.max(x1, light.x);
      y0 = Math.min(y0, light.y); y1 = Math.max(y1, light.y);
    }
    const margin = 15;
    return [x0 - margin, x1 + margin, y0 - margin, y1 + margin];
  }

  // Pose of an actor at time t: reference point x, y and heading h (interpolated).
  pose(name, t) {
    const a = this.scene.actors[name];
    const [i, w] = sampleAt(this.scene.times, t);
    return { x: lerp(a.x, i, w), y: lerp(a.y, i, w), h: lerpAngle(a.h, i, w), speed: lerp(a.speed, i, w), lane: a.lane[i] };
  }

  // World -> canvas pixels for the current camera (y up on screen).
  view() {
    const width = this.canvas.clientWidth, height = this.canvas.clientHeight;
    let cx, cy, scale;
    if (this.camera === "follow" && this.scene.actors[EGO]) {
      // the ego and every actor within FOLLOW_NEAR_M of it, framed with room around them
      const ego = this.pose(EGO, this.t);
      const near = Object.keys(this.scene.actors).filter((n) => this.onRoad(n, this.t)).map((n) => this.pose(n, this.t))
        .filter((p) => Math.hypot(p.x - ego.x, p.y - ego.y) < FOLLOW_NEAR_M);
      if (!near.length) near.push(ego);
      cx = near.reduce((sum, p) => sum + p.x, 0) / near.length;
      cy = near.reduce((sum, p) => sum + p.y, 0) / near.length;
      const reach = Math.max(...near.map((p) => Math.hypot(p.x - cx, p.y - cy)));
      scale = Math.min(width, height) / Math.max(FOLLOW_MIN_M, 2 * reach + 30);
    } else {
      const [x0, x1, y0, y1] = this.bounds;
      cx = (x0 + x1) / 2; cy = (y0 + y1) / 2;
      scale = Math.min(width / (x1 - x0), height / (y1 - y0));
    }
    return { width, height, scale, toPx: (x, y) => [width / 2 + (x - cx) * scale, height / 2 - (y - cy) * scale] };
  }

  // Where each actor's box centre is drawn now, in canvas pixels (read by the tests).
  actorPixels() {
    const v = this.view();
    const found = {};
    for (const name of Object.keys(this.scene.actors)) {
      if (!this.onRoad(name, this.t)) continue;
      const p = this.pose(name, this.t);
      const ahead = this.scene.actors[name].box[2];
      found[name] = v.toPx(p.x + ahead * Math.cos(p.h), p.y + ahead * Math.sin(p.h));
    }
    return found;
  }

  lightColour(light, t) {
    let colour = null;
    for (const [from, , state] of light.spans) if (from <= t + 1e-9) colour = state;
    return colour;
  }

  draw() {
    const canvas = this.canvas, ratio = window.devicePixelRatio || 1;
    if (canvas.width !== Math.round(canvas.clientWidth * ratio)) {
      canvas.width = Math.round(canvas.clientWidth * ratio);
      canvas.height = Math.round(canvas.clientHeight * ratio);
    }
    const ctx = canvas.getContext("2d");
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    const v = this.view();
    ctx.fillStyle = "#eef1f4";
    ctx.fillRect(0, 0, v.width, v.height);
    this.drawLanes(ctx, v);
    this.drawPaths(ctx, v);
    this.drawGhost(ctx, v);
    this.drawStopLine(ctx, v);
    for (const light of this.scene.lights) this.drawLight(ctx, v, light);
    for (const name of Object.keys(this.scene.actors)) if (this.onRoad(name, this.t)) this.drawActor(ctx, v, name);
    this.drawCollisions(ctx, v);
    ctx.fillStyle = "#1f2328";
    ctx.font = "12px system-ui, sans-serif";
    ctx.fillText(`${this.label}t = ${this.t.toFixed(2)} s`, 8, 16);
    this.drawScaleBar(ctx, v);
  }

  drawLanes(ctx, v) {
    for (const lane of this.scene.lanes) {
      ctx.strokeStyle = lane.junction ? "#c8ccd1" : "#8c959f";
      ctx.lineWidth = lane.junction ? 0.6 : 1;
      ctx.beginPath();
      lane.points.forEach(([x, y], i) => { const [px, py] = v.toPx(x, y); if (i) ctx.lineTo(px, py); else ctx.moveTo(px, py); });
      ctx.stroke();
    }
  }

  // each actor's whole path, faint, with a tick every second and the time every 5 s
  drawPaths(ctx, v) {
    const times = this.scene.times;
    for (const [name, actor] of Object.entries(this.scene.actors)) {
      ctx.strokeStyle = this.colours[name];
      ctx.fillStyle = this.colours[name];
      ctx.globalAlpha = 0.35;
      ctx.lineWidth = 1.5;
      ctx.beginPath();
      let drawn = false;
      actor.x.forEach((x, i) => {
        if (!this.onRoad(name, times[i])) { drawn = false; return; }
        const [px, py] = v.toPx(x, actor.y[i]);
        if (drawn) ctx.lineTo(px, py); else ctx.moveTo(px, py);
        drawn = true;
      });
      ctx.stroke();
      ctx.globalAlpha = 0.8;
      ctx.font = "10px system-ui, sans-serif";
      for (let second = 1; second <= times[times.length - 1]; second++) {
        if (!this.onRoad(name, second)) continue;
        const p = this.pose(name, second);
        const [px, py] = v.toPx(p.x, p.y);
        ctx.beginPath(); ctx.arc(px, py, 2, 0, 2 * Math.PI); ctx.fill();
        if (second % 5 === 0) ctx.fillText(`${second} s`, px + 4, py + 12);
      }
      ctx.globalAlpha = 1;
    }
  }

  // the record's stop line across the ego's path (urban records)
  drawStopLine(ctx, v) {
    const c = this.scene.charts && this.scene.charts.stop_line;
    if (!c || !c.at) return;
    const [x, y, h] = c.at, half = 2.5;
    const [ax, ay] = v.toPx(x - half * Math.sin(h), y + half * Math.cos(h));
    const [bx, by] = v.toPx(x + half * Math.sin(h), y - half * Math.cos(h));
    ctx.strokeStyle = "#1f2328";
    ctx.lineWidth = 3;
    ctx.beginPath(); ctx.moveTo(ax, ay); ctx.lineTo(bx, by); ctx.stroke();
    ctx.fillStyle = "#1f2328";
    ctx.fillText("stop line (record)", bx + 4, by + 4);
  }

  // The record's own gap (mined data) as a ghost car ahead of the ego along its heading.
  drawGhost(ctx, v) {
    const gap = this.scene.charts && this.scene.charts.gap;
    if (!gap || !gap.recorded || !gap.recorded_t || !this.scene.actors.npc) return;
    const along = interpolate(gap.recorded_t, gap.recorded, this.t);
    if (along == null) return;
    const ego = this.pose(EGO, this.t);
    const box = this.scene.actors.npc.box;
    const x = ego.x + along * Math.cos(ego.h), y = ego.y + along * Math.sin(ego.h);
    this.drawBox(ctx, v, x, y, ego.h, box, "#e07b00", "record", true);
  }

  drawBox(ctx, v, x, y, h, box, colour, label, ghost) {
    const [length, width, ahead] = box;
    const [px, py] = v.toPx(x + ahead * Math.cos(h), y + ahead * Math.sin(h));
    ctx.save();
    ctx.translate(px, py);
    ctx.rotate(-h);
    ctx.globalAlpha = ghost ? 0.35 : 1;
    ctx.fillStyle = colour;
    ctx.strokeStyle = "#1f2328";
    ctx.lineWidth = 1;
    if (ghost) ctx.setLineDash([3, 3]);
    ctx.fillRect(-length / 2 * v.scale, -width / 2 * v.scale, length * v.scale, width * v.scale);
    ctx.strokeRect(-length / 2 * v.scale, -width / 2 * v.scale, length * v.scale, width * v.scale);
    // the front, so the heading reads at a glance
    ctx.fillStyle = "white";
    ctx.fillRect((length / 2 - Math.min(0.8, length / 5)) * v.scale, -width / 2 * v.scale, Math.min(0.8, length / 5) * v.scale, width * v.scale);
    ctx.restore();
    ctx.globalAlpha = 1;
    ctx.setLineDash([]);
    ctx.fillStyle = "#1f2328";
    ctx.font = "11px system-ui, sans-serif";
    ctx.fillText(label, px + 8, py - 8);
  }

  drawActor(ctx, v, name) {
    const p = this.pose(name, this.t);
    // a crowded scene (in situ: every recorded vehicle) names the cars; the ego keeps its speed
    const crowded = Object.keys(this.scene.actors).length > 8 && name !== EGO;
    const label = crowded ? name : `${name} ${p.speed.toFixed(1)} m/s`;
    this.drawBox(ctx, v, p.x, p.y, p.h, this.scene.actors[name].box, this.colours[name], label, false);
  }

  drawLight(ctx, v, light) {
    const [px, py] = v.toPx(light.x, light.y);
    const colour = this.lightColour(light, this.t);
    ctx.beginPath();
    ctx.arc(px, py, 7, 0, 2 * Math.PI);
    ctx.fillStyle = LIGHT_COLOURS[colour] || "#999";
    ctx.fill();
    ctx.strokeStyle = "#1f2328";
    ctx.lineWidth = 1.5;
    ctx.stroke();
  }

  drawCollisions(ctx, v) {
    for (const [t, a, b] of this.scene.collisions) {
      if (Math.abs(t - this.t) > 0.5 || !this.scene.actors[a] || !this.scene.actors[b] || !this.onRoad(a, t) || !this.onRoad(b, t)) continue;
      const pa = this.pose(a, t), pb = this.pose(b, t);
      const [px, py] = v.toPx((pa.x + pb.x) / 2, (pa.y + pb.y) / 2);
      ctx.strokeStyle = "#cf222e";
      ctx.lineWidth = 3;
      ctx.beginPath();
      ctx.moveTo(px - 9, py - 9); ctx.lineTo(px + 9, py + 9); ctx.moveTo(px + 9, py - 9); ctx.lineTo(px - 9, py + 9);
      ctx.stroke();
    }
  }

  drawScaleBar(ctx, v) {
    const metres = v.scale > 6 ? 10 : v.scale > 1.5 ? 50 : 200;
    const y = v.height - 12;
    ctx.strokeStyle = "#1f2328";
    ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(10, y); ctx.lineTo(10 + metres * v.scale, y); ctx.stroke();
    ctx.fillText(`${metres} m`, 14 + metres * v.scale, y + 4);
  }
}

// One clock for a page: plays at a rate, tells every listener the time.
class Clock {
  constructor(duration) {
    this.duration = duration;
    this.t = 0;
    this.rate = 1;
    this.playing = false;
    this.listeners = [];
    this.last = null;
  }
  on(listener) { this.listeners.push(listener); }
  seek(t) {
    this.t = Math.max(0, Math.min(this.duration, t));
    this.listeners.forEach((listener) => listener(this.t));
  }
  play() {
    if (this.t >= this.duration) this.seek(0);
    this.playing = true;
    this.last = null;
    const step = (now) => {
      if (!this.playing) return;
      if (this.last != null) this.seek(this.t + (now - this.last) / 1000 * this.rate);
      this.last = now;
      if (this.t >= this.duration) { this.playing = false; this.listeners.forEach((l) => l(this.t)); return; }
      requestAnimationFrame(step);
    };
    requestAnimationFrame(step);
  }
  pause() { this.playing = false; this.seek(this.t); }
}

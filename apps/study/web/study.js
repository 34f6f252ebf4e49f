// fabrica-study for the web (`fabrica-study export-web`, docs/study.md):
// the same plans (plans.js, written by the C++ planner), the same screens
// and the same CSV columns as `fabrica-study run`. Each answer is appended
// to the browser's localStorage before the next trial is shown (reloading
// the page resumes at the next unanswered trial, as --resume); the CSV is
// downloaded at the end (or any time) and `fabrica-study analyze` reads it
// from RESULTS/participants/ID/responses.csv.
//
// The core (steps, rows, CSV) has no DOM and runs under node for tests.
"use strict";

const COLUMNS = [
  "participant", "session", "trial", "block", "task", "practice", "attention", "model", "view",
  "technique", "stimulus", "technique_a", "technique_b", "stimulus_a", "stimulus_b", "techniques",
  "stimuli", "pixel_x", "pixel_y", "true_nx", "true_ny", "true_nz", "question", "expected",
  "response", "normal_x", "normal_y", "normal_z", "choice", "chosen_technique", "rating", "order",
  "rt_ms", "wall_time"];

function csvField(s) {
  s = String(s);
  if (!/[",\n\r]/.test(s)) return s;
  return '"' + s.replace(/[\r\n]/g, " ").replace(/"/g, '""') + '"';
}

function csvSplit(line) {
  const out = [""];
  let quoted = false;
  for (let i = 0; i < line.length; ++i) {
    const c = line[i];
    if (quoted) {
      if (c === '"' && line[i + 1] === '"') { out[out.length - 1] += '"'; ++i; }
      else if (c === '"') quoted = false;
      else out[out.length - 1] += c;
    } else if (c === '"') quoted = true;
    else if (c === ",") out.push("");
    else out[out.length - 1] += c;
  }
  return out;
}

const num = (v) => Number(v).toFixed(6);  // as the C++ "%.6f"

function normalize(v) {
  const n = Math.hypot(v[0], v[1], v[2]);
  return [v[0] / n, v[1] / n, v[2] / n];
}

/// One CSV row (strings in COLUMNS order) for an answered trial, exactly as
/// the desktop program writes it.
function makeRow(participant, session, t, answer, rtMs, wallTime) {
  const row = {};
  row.participant = participant;
  row.session = String(session);
  for (const k of ["trial", "block", "task", "model", "view", "technique", "stimulus", "question"])
    row[k] = k in t ? String(t[k]) : "";
  row.practice = t.practice ? "1" : "0";
  row.attention = t.attention ? "1" : "0";
  if ("expected" in t)
    row.expected = Array.isArray(t.expected) ? t.expected.map(num).join(" ") : String(t.expected);
  if ("stimuli" in t) {
    row.techniques = t.techniques.join("|");
    row.stimuli = t.stimuli.join("|");
    if (t.stimuli.length === 2) {
      [row.technique_a, row.technique_b] = t.techniques;
      [row.stimulus_a, row.stimulus_b] = t.stimuli;
    }
  }
  if (t.task === "gauge") {
    row.pixel_x = num(t.pixel[0]);
    row.pixel_y = num(t.pixel[1]);
    [row.true_nx, row.true_ny, row.true_nz] = t.true_normal.map(num);
    [row.normal_x, row.normal_y, row.normal_z] = normalize(answer.normal).map(num);
    row.response = [row.normal_x, row.normal_y, row.normal_z].join(" ");
  } else if (t.task === "2afc") {
    row.choice = String(answer.choice);
    row.chosen_technique = t.techniques[answer.choice];
    row.response = row.choice;
  } else if (t.task === "likert") {
    row.rating = String(answer.rating);
    row.response = row.rating;
  } else {
    row.order = row.response = answer.order.map((i) => t.techniques[i]).join("|");
  }
  row.rt_ms = String(Math.round(rtMs));
  row.wall_time = wallTime;
  return COLUMNS.map((c) => (c in row ? row[c] : ""));
}

const rowLine = (values) => values.map(csvField).join(",") + "\n";
const header = () => COLUMNS.join(",") + "\n";

/// Answered trials and the next session number of a stored log.
function readLog(text) {
  const lines = text.split("\n").filter((l) => l.length);
  const answered = new Set();
  let session = 0;
  for (const l of lines.slice(1)) {
    const f = csvSplit(l);
    session = Math.max(session, Number(f[1]));
    answered.add(Number(f[2]));
  }
  return { answered, session: session + 1 };
}

/// The screens and trials still to show, as the desktop program orders them.
function steps(plan, answered) {
  const out = [];
  const resumed = answered.size > 0;
  let first = true;
  for (const t of plan.trials) {
    if (answered.has(t.trial)) continue;
    if (first && resumed)
      out.push({ screen: "resume", text: `Welcome back. You continue at trial ${t.trial} of ${plan.trials.length}.` });
    first = false;
    for (const s of t.before || []) out.push({ screen: s.screen, text: s.text });
    out.push({ trial: t });
  }
  out.push({ screen: "goodbye", text: plan.goodbye });
  return out;
}

if (typeof module !== "undefined") module.exports = { COLUMNS, makeRow, rowLine, header, readLog, steps, csvSplit };

// ------------------------------------------------------------------ browser
if (typeof document !== "undefined") {
  const app = document.getElementById("app");
  const el = (tag, attrs = {}, ...kids) => {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs)) {
      if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
      else e.setAttribute(k, v);
    }
    for (const k of kids) e.append(k);
    return e;
  };
  const params = new URLSearchParams(location.search);
  const plans = window.FABRICA_PLANS;

  function start(participant) {
    const plan = plans[participant];
    const key = `fabrica-study/${plan.study}/${participant}`;
    let log = localStorage.getItem(key) || header();
    const { answered, session } = readLog(log);
    const todo = steps(plan, answered);
    let i = 0;
    const download = () => {
      const a = el("a", { href: URL.createObjectURL(new Blob([log], { type: "text/csv" })),
                          download: `responses-${participant}.csv` });
      a.click();
    };
    const show = () => {
      app.replaceChildren();
      const s = todo[i];
      if (!s.trial) {
        app.append(el("p", { class: "text" }, s.text),
                   el("button", { onclick: () => { if (s.screen === "goodbye") download(); else { ++i; show(); } } },
                      s.screen === "goodbye" ? "Finish and download the responses" : "Continue"));
        return;
      }
      const t = s.trial;
      const shown = performance.now();
      const commit = (answer) => {
        log += rowLine(makeRow(participant, session, t, answer, performance.now() - shown, new Date().toISOString()));
        localStorage.setItem(key, log);  // stored before the next trial is shown
        ++i;
        show();
      };
      app.append(el("div", {}, `Trial ${t.trial} of ${plan.trials.length}${t.practice ? "  (practice)" : ""}`),
                 el("div", { class: "question" }, t.question));
      const img = (id) => el("img", { src: `stimuli/${id}.png`, width: plan.size[0], height: plan.size[1] });
      if (t.task === "gauge") {
        const canvas = el("canvas", { width: plan.size[0], height: plan.size[1] });
        const ctx = canvas.getContext("2d");
        const picture = new Image();
        let normal = t.initial_normal.slice();
        const draw = () => {
          ctx.drawImage(picture, 0, 0);
          const [cx, cy] = t.pixel, r = 18, n = normalize(normal);
          const a0 = Math.abs(n[2]) < 0.9 ? [0, 0, 1] : [1, 0, 0];
          let a = [a0[1] * n[2] - a0[2] * n[1], a0[2] * n[0] - a0[0] * n[2], a0[0] * n[1] - a0[1] * n[0]];
          a = normalize(a);
          const b = [n[1] * a[2] - n[2] * a[1], n[2] * a[0] - n[0] * a[2], n[0] * a[1] - n[1] * a[0]];
          ctx.strokeStyle = "rgb(0,160,60)";
          ctx.lineWidth = 2;
          ctx.beginPath();
          for (let k = 0; k <= 48; ++k) {
            const th = (2 * Math.PI * k) / 48;
            const x = cx + r * (Math.cos(th) * a[0] + Math.sin(th) * b[0]);
            const y = cy - r * (Math.cos(th) * a[1] + Math.sin(th) * b[1]);
            k ? ctx.lineTo(x, y) : ctx.moveTo(x, y);
          }
          ctx.moveTo(cx, cy);
          ctx.lineTo(cx + 1.2 * r * n[0], cy - 1.2 * r * n[1]);
          ctx.stroke();
        };
        let dragging = false;
        const drag = (e) => {
          if (!dragging) return;
          const box = canvas.getBoundingClientRect();
          const dx = (e.clientX - box.left - t.pixel[0]) / 60, dy = -(e.clientY - box.top - t.pixel[1]) / 60;
          const d = Math.hypot(dx, dy);
          normal = d < 1 ? [dx, dy, Math.sqrt(1 - d * d)] : [dx / d, dy / d, 0];
          draw();
        };
        canvas.addEventListener("mousedown", (e) => { dragging = true; drag(e); });
        canvas.addEventListener("mousemove", drag);
        window.addEventListener("mouseup", () => { dragging = false; });
        picture.onload = draw;
        picture.src = `stimuli/${t.stimulus}.png`;
        app.append(canvas, el("br"), el("button", { onclick: () => commit({ normal }) }, "Next"));
      } else if (t.task === "2afc") {
        app.append(...t.stimuli.map((id, k) => el("span", { class: "pick", onclick: () => commit({ choice: k }) }, img(id))),
                   el("div", {}, "Click a picture to choose it."));
      } else if (t.task === "likert") {
        let rating = null;
        const next = el("button", { disabled: "", onclick: () => commit({ rating }) }, "Next");
        const radios = el("div");
        for (let k = 1; k <= t.scale; ++k)
          radios.append(el("label", {}, el("input", { type: "radio", name: "r", onchange: () => { rating = k; next.removeAttribute("disabled"); } }), ` ${k} `));
        app.append(img(t.stimulus), radios, next);
      } else {
        const order = t.stimuli.map((_, k) => k);
        const row = el("div");
        const redraw = () => {
          row.replaceChildren(...order.map((k, p) => el("span", { class: "rank" }, img(t.stimuli[k]), el("br"), `${p + 1}. `,
            el("button", { onclick: () => { if (p > 0) { [order[p - 1], order[p]] = [order[p], order[p - 1]]; redraw(); } } }, "◀"),
            el("button", { onclick: () => { if (p + 1 < order.length) { [order[p + 1], order[p]] = [order[p], order[p + 1]]; redraw(); } } }, "▶"))));
        };
        redraw();
        app.append(row, el("button", { onclick: () => commit({ order: order.slice() }) }, "Next"));
      }
      app.append(el("p", {}, el("a", { href: "#", onclick: (e) => { e.preventDefault(); download(); } }, "download the responses so far")));
    };
    show();
  }

  const id = params.get("participant");
  if (id && /^[A-Za-z0-9_-]{1,64}$/.test(id) && plans[id]) start(id);
  else {
    const input = el("input", { placeholder: "participant id, e.g. P01" });
    app.append(el("p", {}, id ? `Unknown participant id "${id}".` : "Enter your participant id."), input,
               el("button", { onclick: () => { if (plans[input.value]) start(input.value); } }, "Start"));
  }
}

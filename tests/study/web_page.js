// Drives the exported web page itself (index.html's study.js, DOM part) in
// node with a minimal fake DOM: reads the screen, answers like a person
// (mouse drag on the gauge canvas, clicks on pictures, radio buttons, arrow
// buttons), clicks through, and writes the CSV the last screen downloads.
//   node web_page.js WEB_DIR PARTICIPANT ANSWERS.jsonl OUT.csv
"use strict";
const fs = require("fs");
const path = require("path");
const vm = require("vm");
const [dir, participant, answersFile, outFile] = process.argv.slice(2);
const answers = new Map();
for (const line of fs.readFileSync(answersFile, "utf8").split("\n").filter((l) => l.trim()))
  answers.set(JSON.parse(line).trial, JSON.parse(line));

class El {
  constructor(tag) { Object.assign(this, { tag, children: [], attrs: {}, listeners: {} }); }
  append(...kids) { for (const k of kids) this.children.push(typeof k === "string" ? { text: k } : k); }
  replaceChildren(...kids) { this.children = []; this.append(...kids); }
  setAttribute(k, v) { this.attrs[k] = String(v); }
  removeAttribute(k) { delete this.attrs[k]; }
  addEventListener(type, f) { (this.listeners[type] = this.listeners[type] || []).push(f); }
  fire(type, e = {}) { for (const f of this.listeners[type] || []) f({ preventDefault() {}, ...e }); }
  click() { if (!("disabled" in this.attrs)) this.fire("click"); }
  getContext() { return new Proxy({}, { get: () => () => {}, set: () => true }); }
  getBoundingClientRect() { return { left: 0, top: 0 }; }
  text() { return this.children.map((c) => (c instanceof El ? c.text() : c.text)).join(""); }
  all(pred, out = []) {
    if (pred(this)) out.push(this);
    for (const c of this.children) if (c instanceof El) c.all(pred, out);
    return out;
  }
}
const app = new El("div");
let downloaded = null;
const winListeners = {};
const storage = new Map();
const context = {
  document: { getElementById: () => app, createElement: (t) => new El(t) },
  location: { search: `?participant=${participant}` },
  localStorage: { getItem: (k) => (storage.has(k) ? storage.get(k) : null), setItem: (k, v) => storage.set(k, v) },
  performance: { now: () => 0 },
  Image: class { set src(v) { if (this.onload) this.onload(); } },
  Blob: class { constructor(parts) { this.text = parts.join(""); } },
  URL: { createObjectURL: (b) => { downloaded = b.text; return "blob:"; } },
  URLSearchParams, Date, Math, Object, Number, String, Set, Map, Array, JSON, performance: { now: () => 0 },
};
context.window = context;
context.window.addEventListener = (t, f) => { winListeners[t] = f; };
vm.createContext(context);
for (const f of ["plans.js", "study.js"]) vm.runInContext(fs.readFileSync(path.join(dir, f), "utf8"), context);
const plan = context.FABRICA_PLANS[participant];
const byNumber = new Map(plan.trials.map((t) => [t.trial, t]));

for (let guard = 0; guard < 10000 && downloaded === null; ++guard) {
  const m = /^Trial (\d+) of/.exec(app.text());
  const buttons = app.all((e) => e.tag === "button");
  if (!m) { buttons[0].click(); continue; }  // a screen: Continue / Finish
  const t = byNumber.get(Number(m[1]));
  const a = answers.get(t.trial);
  const next = () => buttons.find((b) => b.text() === "Next").click();
  if (t.task === "gauge") {
    const canvas = app.all((e) => e.tag === "canvas")[0];
    const [nx, ny] = a.normal;
    canvas.fire("mousedown", { clientX: t.pixel[0] + 60 * nx, clientY: t.pixel[1] - 60 * ny });
    winListeners.mouseup();
    next();
  } else if (t.task === "2afc") {
    app.all((e) => e.attrs.class === "pick")[a.choice].click();
  } else if (t.task === "likert") {
    app.all((e) => e.tag === "input")[a.rating - 1].fire("change");
    next();
  } else {
    const want = a.order.map((x) => (typeof x === "number" ? x : t.techniques.indexOf(x)));
    const order = t.stimuli.map((_, k) => k);
    for (let p = 0; p < want.length; ++p) {  // bring want[p] to position p with left arrows
      for (let q = order.indexOf(want[p]); q > p; --q) {
        app.all((e) => e.tag === "button" && e.text() === "◀")[q].click();
        [order[q - 1], order[q]] = [order[q], order[q - 1]];
      }
    }
    app.all((e) => e.tag === "button" && e.text() === "Next")[0].click();
  }
}
if (downloaded === null) throw new Error("the page never offered the responses for download");
fs.writeFileSync(outFile, downloaded);

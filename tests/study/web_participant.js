// Scripted participant for the web export (run by study_tests.py under node):
//   node web_participant.js WEB_DIR PARTICIPANT ANSWERS.jsonl OUT.csv [STOP_AFTER]
// Walks the page's own steps() and makeRow() (study.js core, no DOM) as the
// page does, answering from the file; with STOP_AFTER, stops after that many
// answers and then resumes from the stored log (as a page reload would).
"use strict";
const fs = require("fs");
const path = require("path");
const [dir, participant, answersFile, outFile, stopAfter] = process.argv.slice(2);
global.window = {};
eval(fs.readFileSync(path.join(dir, "plans.js"), "utf8"));
const core = require(path.resolve(dir, "study.js"));
const plan = window.FABRICA_PLANS[participant];
const answers = new Map();
for (const line of fs.readFileSync(answersFile, "utf8").split("\n").filter((l) => l.trim()))
  answers.set(JSON.parse(line).trial, JSON.parse(line));

function session(log, limit) {
  const { answered, session } = core.readLog(log);
  const todo = core.steps(plan, answered);
  let n = 0;
  const kinds = [];
  for (const s of todo) {
    kinds.push(s.trial ? s.trial.task : s.screen);
    if (!s.trial) continue;
    if (n === limit) break;
    const t = s.trial;
    const a = Object.assign({}, answers.get(t.trial));
    if (a.order) a.order = a.order.map((x) => (typeof x === "number" ? x : t.techniques.indexOf(x)));
    log += core.rowLine(core.makeRow(participant, session, t, a, 0, "2026-01-01T00:00:00.000Z"));
    ++n;
  }
  return { log, kinds };
}

let { log } = session(core.header(), stopAfter ? Number(stopAfter) : -1);
if (stopAfter) {
  const resumed = session(log, -1);
  if (resumed.kinds[0] !== "resume") throw new Error("a reload does not start with the resume screen");
  log = resumed.log;
}
fs.writeFileSync(outFile, log);

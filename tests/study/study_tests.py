#!/usr/bin/python3
"""Tests of fabrica-study (issue 20), run by ctest: study_tests.py CASE --build DIR ...

Cases: plan (determinism, Latin square, validation), e2e (window under
xvfb-run: plan -> scripted participant -> CSV -> analyze; kill -9 and
--resume), stimuli (same pixels drawn live or read from a folder),
analysis (known effects recovered from synthetic participants).
Each case exits non-zero with a message on the first failed check.
"""
import argparse
import csv
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np

A = None  # parsed arguments


def check(cond, message):
    if not cond:
        print("FAILED: " + message, file=sys.stderr)
        sys.exit(1)


def study_bin(*args, **kw):
    return subprocess.run([A.study, *args], capture_output=True, text=True, **kw)


def write_study(path, techniques=None, blocks=None, **extra):
    meshes = A.meshes
    s = {
        "name": "test study", "seed": 7, "size": [256, 256],
        "techniques": techniques or [
            {"name": "contours", "command": "lines", "types": "contour,suggestive", "width": 2.0},
            {"name": "shaded", "command": "render", "style": "lambert", "lines": "none"},
            {"name": "ridges", "command": "lines", "types": "contour,apparent"},
        ],
        "models": [{"mesh": os.path.join(meshes, "meshes/anatomy/liver/sofa_liver-smooth.obj"),
                    "name": "liver"}],
        "views": ["anterior"],
        "blocks": blocks or [
            {"task": "gauge", "points_per_stimulus": 2, "practice": 1, "attention_checks": 1},
            {"task": "2afc", "question": "Which shows the shape better?", "pairs": "all", "repeats": 1},
            {"task": "likert", "scale": 5, "question": "How clear?"},
            {"task": "ranking"},
        ],
    }
    s.update(extra)
    with open(path, "w") as f:
        json.dump(s, f, indent=1)
    return path


def fresh(name):
    d = os.path.join(A.work, name)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    return d


def plan_of(study, participant, out):
    r = study_bin("plan", study, "--participant", participant, "-o", out)
    check(r.returncode == 0, f"plan {participant}: exit {r.returncode}: {r.stderr}")
    with open(out, "rb") as f:
        return f.read()


# ---------------------------------------------------------------- plan
def case_plan():
    d = fresh("plan")
    study = write_study(os.path.join(d, "study.json"))
    a = plan_of(study, "P01", os.path.join(d, "a.json"))
    b = plan_of(study, "P01", os.path.join(d, "b.json"))
    check(a == b, "the same participant's plan differs between runs")
    c = plan_of(study, "P02", os.path.join(d, "c.json"))
    pa, pc = json.loads(a), json.loads(c)
    check([t.get("stimulus") for t in pa["trials"]] != [t.get("stimulus") for t in pc["trials"]],
          "P01 and P02 have the same trial order")
    check(pa["technique_order"] != pc["technique_order"], "P01 and P02 share a technique order")
    trials = pa["trials"]
    check([t["trial"] for t in trials] == list(range(1, len(trials) + 1)), "trials are not numbered 1..N")
    gauge = [t for t in trials if t["task"] == "gauge"]
    check(len(gauge) == 3 * 2 + 1 + 1, f"expected 8 gauge trials (6 + practice + check), got {len(gauge)}")
    for t in gauge:
        n = np.array(t["true_normal"])
        check(abs(np.linalg.norm(n) - 1) < 1e-5 and n[2] > 0, f"trial {t['trial']}: true_normal {n} not unit/facing")
        check(0 <= t["pixel"][0] < 256 and 0 <= t["pixel"][1] < 256, "gauge pixel outside the image")
        check(t["technique"] in t["stimulus"], "gauge stimulus id does not name its technique")
    # The same surface points for every technique (a study-level sample).
    pts = {}
    for t in gauge:
        if not t["practice"] and not t["attention"]:
            pts.setdefault(t["technique"], set()).add(tuple(t["pixel"]))
    check(len({frozenset(v) for v in pts.values()}) == 1, "techniques judge different gauge points")
    afc = [t for t in trials if t["task"] == "2afc"]
    check(len(afc) == 3 and all(len(t["stimuli"]) == 2 and len(t["techniques"]) == 2 for t in afc),
          "2afc trials need stimuli [a,b] and techniques [ta,tb], 3 pairs")
    check(trials[0]["before"][0]["screen"] == "welcome", "no welcome screen before trial 1")
    # Latin square (Williams): with 3 techniques, 6 rows; P1..P6 put each technique
    # in each position equally often, and each ordered neighbour pair equally often.
    orders = [json.loads(plan_of(study, f"P{i}", os.path.join(d, f"p{i}.json")))["technique_order"]
              for i in range(1, 7)]
    for pos in range(3):
        counts = {n: sum(o[pos] == n for o in orders) for n in ("contours", "shaded", "ridges")}
        check(set(counts.values()) == {2}, f"position {pos}: unbalanced {counts}")
    pairs = {}
    for o in orders:
        for x, y in zip(o, o[1:]):
            pairs[(x, y)] = pairs.get((x, y), 0) + 1
    check(len(pairs) == 6 and set(pairs.values()) == {2}, f"neighbour pairs unbalanced: {pairs}")
    # Strict validation: unknown keys name their JSON path; exit 2.
    bad = json.load(open(study))
    bad["blocks"][1]["repeat"] = 2
    with open(os.path.join(d, "bad.json"), "w") as f:
        json.dump(bad, f)
    r = study_bin("plan", os.path.join(d, "bad.json"), "--participant", "P1", "-o", os.path.join(d, "x.json"))
    check(r.returncode == 2 and "blocks[1].repeat" in r.stderr, f"unknown key: exit {r.returncode}: {r.stderr}")
    bad = json.load(open(study))
    bad["techniques"][0]["colour"] = "red"
    with open(os.path.join(d, "bad2.json"), "w") as f:
        json.dump(bad, f)
    r = study_bin("plan", os.path.join(d, "bad2.json"), "--participant", "P1", "-o", os.path.join(d, "x.json"))
    check(r.returncode == 2 and "techniques[0].colour" in r.stderr, f"unknown option: {r.stderr}")
    # A size that wraps to 256 in a 32-bit int (2^32 + 256) is refused, not read as 256.
    bad = json.load(open(study))
    bad["size"] = [4294967552, 256]
    with open(os.path.join(d, "bad3.json"), "w") as f:
        json.dump(bad, f)
    r = study_bin("plan", os.path.join(d, "bad3.json"), "--participant", "P1", "-o", os.path.join(d, "x.json"))
    check(r.returncode == 2 and "size" in r.stderr, f"a wrapping size was accepted: exit {r.returncode}: {r.stderr}")
    r = study_bin("plan", study, "--participant", "../etc", "-o", os.path.join(d, "x.json"))
    check(r.returncode == 2 and "participant" in r.stderr, f"bad participant id accepted: {r.stderr}")
    check(not os.path.exists(os.path.join(d, "x.json")), "a failed plan left a file")
    # Ground truth: on a sphere the true normal at a pixel is known exactly
    # (ray through the pixel centre, nearest intersection, (p - c) / r).
    sphere = os.path.join(d, "sphere.obj")
    with open(sphere, "w") as f:
        nu, nv, R = 96, 48, 20.0
        for i in range(nv + 1):
            th = math.pi * i / nv
            for j in range(nu):
                ph = 2 * math.pi * j / nu
                f.write(f"v {R*math.sin(th)*math.cos(ph)} {R*math.sin(th)*math.sin(ph)} {R*math.cos(th)}\n")
        for i in range(nv):
            for j in range(nu):
                a, b = i * nu + j + 1, i * nu + (j + 1) % nu + 1
                c, e = a + nu, b + nu
                f.write(f"f {a} {c} {e}\nf {a} {e} {b}\n")
    sph = write_study(os.path.join(d, "sphere.json"), techniques=[{"name": "shaded", "command": "render"}],
                      blocks=[{"task": "gauge", "points_per_stimulus": 12}])
    s = json.load(open(sph))
    s["models"] = [{"mesh": sphere}]
    s["views"] = ["anterior", "left"]
    json.dump(s, open(sph, "w"))
    p = json.loads(plan_of(sph, "P1", os.path.join(d, "sphere-plan.json")))
    worst = 0.0
    for t in p["trials"]:
        cam = p["cameras"][f"sphere.{t['view']}"]
        eye, ctr, up = (np.array(cam[k], float) for k in ("eye", "center", "up"))
        fwd = (ctr - eye) / np.linalg.norm(ctr - eye)
        right = np.cross(fwd, up)
        right /= np.linalg.norm(right)
        tup = np.cross(right, fwd)
        h = math.tan(math.radians(cam["fov_deg"]) / 2)
        x = (2 * t["pixel"][0] / cam["width"] - 1) * cam["width"] / cam["height"]
        y = 1 - 2 * t["pixel"][1] / cam["height"]
        ray = fwd + x * h * right + y * h * tup
        ray /= np.linalg.norm(ray)
        bq = ray @ eye
        tt = -bq - math.sqrt(bq * bq - (eye @ eye - R * R))  # sphere centred at the origin
        n = (eye + tt * ray) / R
        nv_ = np.array([n @ right, n @ tup, -(n @ fwd)])
        worst = max(worst, math.degrees(math.acos(min(1.0, nv_ @ np.array(t["true_normal"])))))
    check(len(p["trials"]) == 24 and worst < 1.0, f"sphere: true normals off by up to {worst:.2f} deg")
    print(f"sphere: true normals within {worst:.3f} deg of the exact ones")

    # The documented sample study is valid (model paths pointed at the test data).
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    sample = json.load(open(os.path.join(root, "examples", "study", "sample-study.json")))
    sample["models"] = [{"mesh": os.path.join(root, "data", "aneurysm.off"), "name": "aneurysm"},
                        {"mesh": os.path.join(A.meshes, "meshes/anatomy/liver/sofa_liver-smooth.obj"),
                         "name": "liver"}]
    json.dump(sample, open(os.path.join(d, "sample.json"), "w"))
    p = json.loads(plan_of(os.path.join(d, "sample.json"), "P01", os.path.join(d, "sample-plan.json")))
    check({t["task"] for t in p["trials"]} == {"gauge", "2afc", "likert", "ranking"}, "sample study tasks")
    check(len(p["technique_order"]) == 5, "the sample study compares five techniques")

    # A scene model and a camera-file view (render techniques only).
    data = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "data")
    with open(os.path.join(d, "cam.json"), "w") as f:
        json.dump({"eye": [0, -80, 0], "center": [0, 0, 0], "up": [0, 0, 1], "fov_deg": 40}, f)
    render_only = [{"name": "shaded", "command": "render"}, {"name": "toon", "command": "render", "style": "toon"}]
    scene_study = write_study(os.path.join(d, "scene.json"), techniques=render_only,
                              blocks=[{"task": "gauge", "points_per_stimulus": 2}])
    s = json.load(open(scene_study))
    s["models"] = [{"scene": os.path.join(data, "aneurysm-scene.json"), "name": "aneurysm"}]
    s["views"] = ["anterior", {"camera": os.path.join(d, "cam.json"), "name": "front"}]
    json.dump(s, open(scene_study, "w"))
    p = json.loads(plan_of(scene_study, "P1", os.path.join(d, "scene-plan.json")))
    check({t["view"] for t in p["trials"]} == {"anterior", "front"}, "camera-file view not planned")
    s["techniques"].append({"name": "lines", "command": "lines"})
    json.dump(s, open(scene_study, "w"))
    r = study_bin("plan", scene_study, "--participant", "P1", "-o", os.path.join(d, "x.json"))
    check(r.returncode == 2 and "models[0]" in r.stderr, f"a scene drawn by lines was accepted: {r.stderr}")
    print("plan: ok")


# ---------------------------------------------------------------- scripted participants
def rotate_noise(n, sigma_deg, rng):
    n = np.asarray(n, float)
    a = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    s = math.radians(sigma_deg)
    m = n + s * (rng.normal() * a + rng.normal() * b)
    return m / np.linalg.norm(m)


def answers_for(plan, rng, sigma=None):
    out = []
    for t in plan["trials"]:
        n = t["trial"]
        if t["task"] == "gauge":
            if t["attention"]:
                v = [0.0, 0.0, 1.0]
            else:
                v = rotate_noise(t["true_normal"], (sigma or {}).get(t["technique"], 10.0), rng).tolist()
            out.append({"trial": n, "normal": v})
        elif t["task"] == "2afc":
            out.append({"trial": n, "choice": int(t["expected"]) if t["attention"] else
                        int(t["techniques"][1] == "contours")})
        elif t["task"] == "likert":
            out.append({"trial": n, "rating": int(t["expected"]) if t["attention"] else 3})
        else:
            out.append({"trial": n, "order": list(reversed(t["techniques"]))})
    return out


def write_jsonl(path, rows):
    with open(path, "w") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def run_env():
    env = dict(os.environ)
    env["FABRICA_BIN"] = A.fabrica
    return env


def case_e2e():
    d = fresh("e2e")
    study = write_study(os.path.join(d, "study.json"))
    out = os.path.join(d, "results")
    # Stimuli drawn once (cached for every participant).
    r = study_bin("stimuli", study, "-o", out, "-q", env=run_env())
    check(r.returncode == 0, f"stimuli: {r.stderr}")
    rng = np.random.default_rng(1)
    for p in ("P1", "P2"):
        plan = json.loads(plan_of(study, p, os.path.join(d, f"plan-{p}.json")))
        write_jsonl(os.path.join(d, f"{p}.jsonl"), answers_for(plan, rng))
        shots = ["--screenshots", os.path.join(d, "screens")] if p == "P1" else []
        r = study_bin("run", study, "--participant", p, "--out", out, "--auto",
                      os.path.join(d, f"{p}.jsonl"), "-q", *shots, env=run_env(), timeout=300)
        check(r.returncode == 0, f"run {p}: exit {r.returncode}: {r.stderr}")
        rows = read_rows(os.path.join(out, "participants", p, "responses.csv"))
        check([int(x["trial"]) for x in rows] == [t["trial"] for t in plan["trials"]],
              f"{p}: logged trials differ from the plan")
        for x, t in zip(rows, plan["trials"]):
            check(x["task"] == t["task"] and x["participant"] == p and x["session"] == "1", "row fields")
            if t["task"] == "gauge":
                check(abs(float(x["true_nx"]) - t["true_normal"][0]) < 1e-5, "true normal not logged")
            if t["task"] == "2afc":
                check(x["stimulus_a"] == t["stimuli"][0] and x["chosen_technique"] in t["techniques"], "2afc row")
        with open(os.path.join(out, "participants", p, "plan.json"), "rb") as f:
            check(f.read() == open(os.path.join(d, f"plan-{p}.json"), "rb").read(),
                  "the run's plan differs from `plan`")
    kinds = sorted(os.listdir(os.path.join(d, "screens")))
    for k in ("welcome", "instructions", "practice", "gauge", "2afc", "likert", "ranking", "goodbye"):
        check(any(k in x for x in kinds), f"no screenshot of the {k} screen: {kinds}")
    # Never overwritten: a second run of P1 without --resume is refused.
    before = open(os.path.join(out, "participants", "P1", "responses.csv"), "rb").read()
    r = study_bin("run", study, "--participant", "P1", "--out", out, "--auto",
                  os.path.join(d, "P1.jsonl"), env=run_env())
    check(r.returncode == 2 and "--resume" in r.stderr, f"existing log: exit {r.returncode}: {r.stderr}")
    check(open(os.path.join(out, "participants", "P1", "responses.csv"), "rb").read() == before,
          "an existing log was modified")
    r = study_bin("run", study, "--participant", "bad id!", "--out", out, env=run_env())
    check(r.returncode == 2, "an invalid participant id was accepted")
    # No display: exit 4, and no log is started (a later run needs no --resume).
    nodisplay = {k: v for k, v in run_env().items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    r = study_bin("run", study, "--participant", "P9", "--out", out, env=nodisplay)
    check(r.returncode == 4 and "xvfb-run" in r.stderr, f"no display: exit {r.returncode}: {r.stderr}")
    check(not os.path.exists(os.path.join(out, "participants", "P9", "responses.csv")),
          "a run without a display started a log")

    # kill -9 after N responses: the auto file answers only N trials, then the
    # window waits for a human; kill it there.
    N = 5
    plan = json.loads(plan_of(study, "P3", os.path.join(d, "plan-P3.json")))
    answers = answers_for(plan, rng)
    write_jsonl(os.path.join(d, "P3-part.jsonl"), answers[:N])
    write_jsonl(os.path.join(d, "P3.jsonl"), answers)
    log = os.path.join(out, "participants", "P3", "responses.csv")
    proc = subprocess.Popen([A.study, "run", study, "--participant", "P3", "--out", out, "--auto",
                             os.path.join(d, "P3-part.jsonl"), "-q"], env=run_env())
    deadline = time.time() + 120
    while time.time() < deadline:
        if os.path.exists(log) and len(read_rows(log)) >= N:
            break
        check(proc.poll() is None, f"run exited early with {proc.returncode}")
        time.sleep(0.1)
    time.sleep(0.5)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    text = open(log).read()
    check(text.endswith("\n"), "torn last line after kill -9")
    rows = read_rows(log)
    check([int(x["trial"]) for x in rows] == list(range(1, N + 1)), f"after kill -9: trials {[x['trial'] for x in rows]}")
    plan_before = open(os.path.join(out, "participants", "P3", "plan.json"), "rb").read()
    # Should a row ever be torn (power cut inside the write), resuming cuts it off.
    with open(log, "a") as f:
        f.write("P3,1,6,1,gau")
    r = study_bin("run", study, "--participant", "P3", "--out", out, "--auto",
                  os.path.join(d, "P3.jsonl"), "--resume", "-q", env=run_env(), timeout=300)
    check(r.returncode == 0, f"resume: {r.stderr}")
    rows = read_rows(log)
    check([int(x["trial"]) for x in rows] == [t["trial"] for t in plan["trials"]], "resume did not complete the plan")
    check(all(x["session"] == ("1" if int(x["trial"]) <= N else "2") for x in rows),
          "resumed rows are not session 2 from trial N+1")
    check(open(os.path.join(out, "participants", "P3", "plan.json"), "rb").read() == plan_before,
          "the plan changed on resume")

    rep = os.path.join(d, "report")
    r = study_bin("analyze", out, "-o", rep)
    check(r.returncode == 0, f"analyze: {r.stderr}")
    report = json.load(open(os.path.join(rep, "report.json")))
    for t in ("contours", "shaded", "ridges"):
        g = report["gauge"]["techniques"][t]
        check(g["ci95"][0] <= g["mean_error_deg"] <= g["ci95"][1], "gauge CI does not hold the mean")
        check(t in report["2afc"]["bradley_terry"], "no Bradley-Terry score")
    # Balanced design: the mixed model's intercept is the first technique's mean.
    fe = report["gauge"]["mixed_model"]["fixed_effects"]
    check(abs(fe["Intercept"]["estimate"] - report["gauge"]["techniques"]["contours"]["mean_error_deg"]) < 0.5,
          f"mixed model intercept {fe['Intercept']} is not the mean of contours")
    check(report["2afc"]["order_best_first"][0] == "contours", "2afc: contours always chosen, not first")
    check(report["ranking"]["schulze_order"] == ["ridges", "shaded", "contours"] or
          len(report["ranking"]["schulze_order"]) == 3, "ranking order")
    check(report["attention_checks"]["P1"]["passed"] == report["attention_checks"]["P1"]["checks"],
          "attention checks answered right are reported failed")
    for p in ("gauge_mean_error.png", "gauge_mean_error.svg", "2afc_bradley_terry.png", "likert.svg"):
        check(os.path.exists(os.path.join(rep, p)), f"plot {p} missing")
    print("e2e: ok")


# ---------------------------------------------------------------- stimuli folder
def case_stimuli():
    d = fresh("stimuli")
    study = write_study(os.path.join(d, "study.json"), techniques=[
        {"name": "shaded", "command": "render", "style": "lambert", "lines": "contour"},
        {"name": "contours", "command": "lines", "types": "contour"}],
        blocks=[{"task": "likert", "scale": 3}])
    live = os.path.join(d, "live")
    r = study_bin("stimuli", study, "-o", live, "-q", env=run_env())
    check(r.returncode == 0, f"stimuli: {r.stderr}")
    # The same picture exported by `fabrica render` itself, with the study's camera.
    exported = os.path.join(d, "exported")
    os.makedirs(exported)
    mesh = os.path.join(A.meshes, "meshes/anatomy/liver/sofa_liver-smooth.obj")
    r = subprocess.run([A.fabrica, "render", mesh, "--camera", os.path.join(live, "cameras", "liver.anterior.json"),
                        "--style", "lambert", "--lines", "contour", "-o",
                        os.path.join(exported, "shaded.liver.anterior.png"), "-q"], capture_output=True, text=True)
    check(r.returncode == 0, f"fabrica render: {r.stderr}")
    import matplotlib.image as mpimg
    a = mpimg.imread(os.path.join(live, "stimuli", "shaded.liver.anterior.png"))
    b = mpimg.imread(os.path.join(exported, "shaded.liver.anterior.png"))
    check(a.shape == b.shape == (256, 256, 4) and np.array_equal(a, b), "live and exported pixels differ")
    check(a[..., :3].std() > 0.01, "the stimulus is blank")
    shutil.copy(os.path.join(live, "stimuli", "contours.liver.anterior.png"), exported)
    # A run reading the folder draws nothing and shows those files.
    plan = json.loads(plan_of(study, "P1", os.path.join(d, "plan.json")))
    write_jsonl(os.path.join(d, "a.jsonl"), [{"trial": t["trial"], "rating": 2} for t in plan["trials"]])
    out = os.path.join(d, "out")
    r = study_bin("run", study, "--participant", "P1", "--out", out, "--stimuli", exported, "--auto",
                  os.path.join(d, "a.jsonl"), "-q", env={**run_env(), "FABRICA_BIN": "/nonexistent"})
    check(r.returncode == 0, f"run --stimuli: {r.stderr}")
    check(not os.path.exists(os.path.join(out, "stimuli")), "run --stimuli drew stimuli")
    # The output folder of `fabrica-study stimuli` is accepted as it is (stimuli/ inside).
    r = study_bin("run", study, "--participant", "P3", "--out", out, "--stimuli", live, "--auto",
                  os.path.join(d, "a.jsonl"), "-q", env={**run_env(), "FABRICA_BIN": "/nonexistent"})
    check(r.returncode == 0, f"run --stimuli STIMULI_OUTPUT: {r.stderr}")
    os.remove(os.path.join(exported, "contours.liver.anterior.png"))
    r = study_bin("run", study, "--participant", "P2", "--out", out, "--stimuli", exported, "-q")
    check(r.returncode == 2 and "contours.liver.anterior.png" in r.stderr, f"missing stimulus: {r.stderr}")
    print("stimuli: ok")


# ---------------------------------------------------------------- web export
def case_web():
    d = fresh("web")
    study = write_study(os.path.join(d, "study.json"))
    web = os.path.join(d, "web")
    r = study_bin("export-web", study, "-o", web, "--participants", "P1,P2", "-q", env=run_env())
    check(r.returncode == 0, f"export-web: {r.stderr}")
    for f in ("index.html", "study.js", "plans.js"):
        check(os.path.exists(os.path.join(web, f)), f"export-web wrote no {f}")
    plans_js = open(os.path.join(web, "plans.js")).read()
    plans = json.loads(plans_js[plans_js.index("=") + 1:].rstrip().rstrip(";"))
    plan = json.loads(plan_of(study, "P1", os.path.join(d, "plan-P1.json")))
    check(plans["P1"] == plan, "the web plan differs from `fabrica-study plan`")
    for t in plan["trials"]:
        for sid in t.get("stimuli", [t.get("stimulus")]):
            check(os.path.exists(os.path.join(web, "stimuli", sid + ".png")), f"web stimulus {sid} missing")
    answers = os.path.join(d, "P1.jsonl")
    write_jsonl(answers, answers_for(plan, np.random.default_rng(3)))
    # The desktop program and the web page answer the same: the same rows.
    out = os.path.join(d, "desktop")
    r = study_bin("run", study, "--participant", "P1", "--out", out, "--auto", answers, "-q", env=run_env())
    check(r.returncode == 0, f"run: {r.stderr}")
    web_csv = os.path.join(d, "web-P1.csv")
    r = subprocess.run([A.node, os.path.join(os.path.dirname(__file__), "web_participant.js"), web, "P1", answers,
                        web_csv, "4"], capture_output=True, text=True)
    check(r.returncode == 0, f"node: {r.stderr}")
    desk = read_rows(os.path.join(out, "participants", "P1", "responses.csv"))
    webr = read_rows(web_csv)
    check(open(web_csv).readline() == open(os.path.join(out, "participants", "P1", "responses.csv")).readline(),
          "web and desktop CSV headers differ")
    check(len(desk) == len(webr), f"{len(webr)} web rows, {len(desk)} desktop rows")
    for a, b in zip(desk, webr):
        for c in a:
            if c not in ("session", "rt_ms", "wall_time"):
                check(a[c] == b[c], f"trial {a['trial']}: column {c}: desktop {a[c]!r}, web {b[c]!r}")
        check(b["session"] == ("1" if int(b["trial"]) <= 4 else "2"), "web resume is not session 2")
    # The page itself (DOM code, fake DOM): clicks and drags give the same rows.
    page_csv = os.path.join(d, "page-P1.csv")
    r = subprocess.run([A.node, os.path.join(os.path.dirname(__file__), "web_page.js"), web, "P1", answers,
                        page_csv], capture_output=True, text=True)
    check(r.returncode == 0, f"node web_page.js: {r.stderr}")
    pager = read_rows(page_csv)
    check(len(pager) == len(desk), f"{len(pager)} rows from the page, {len(desk)} from the desktop")
    for a, b in zip(desk, pager):
        for c in a:
            if c in ("normal_x", "normal_y", "normal_z") and a[c]:
                check(abs(float(a[c]) - float(b[c])) < 2e-6, f"trial {a['trial']}: {c}: {a[c]} vs {b[c]}")
            elif c not in ("session", "rt_ms", "wall_time", "response"):
                check(a[c] == b[c], f"page trial {a['trial']}: column {c}: desktop {a[c]!r}, page {b[c]!r}")
    res = os.path.join(d, "results", "participants", "P1")
    os.makedirs(res)
    shutil.copy(web_csv, os.path.join(res, "responses.csv"))
    r = study_bin("analyze", os.path.join(d, "results"), "-o", os.path.join(d, "report"))
    check(r.returncode == 0, f"analyze of the web CSV: {r.stderr}")
    print("web: ok")


# ---------------------------------------------------------------- analysis recovery
COLUMNS = ["participant", "session", "trial", "block", "task", "practice", "attention", "model", "view",
           "technique", "stimulus", "technique_a", "technique_b", "stimulus_a", "stimulus_b", "techniques",
           "stimuli", "pixel_x", "pixel_y", "true_nx", "true_ny", "true_nz", "question", "expected",
           "response", "normal_x", "normal_y", "normal_z", "choice", "chosen_technique", "rating", "order",
           "rt_ms", "wall_time"]


def write_log(folder, participant, rows):
    p = os.path.join(folder, "participants", participant)
    os.makedirs(p, exist_ok=True)
    with open(os.path.join(p, "responses.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, COLUMNS)
        w.writeheader()
        for i, r in enumerate(rows, 1):
            base = {c: "" for c in COLUMNS}
            base.update({"participant": participant, "session": 1, "trial": i, "block": 1, "practice": 0,
                         "attention": 0, "rt_ms": 1000, "wall_time": "2026-01-01T00:00:00.000Z"})
            base.update(r)
            w.writerow(base)


def case_analysis():
    d = fresh("analysis")
    rng = np.random.default_rng(12345)
    sigma = {"contours": 8.0, "shaded": 16.0, "ridges": 28.0}
    # Expected mean angular error for tangent noise of size sigma: E[atan(s R)], R ~ Rayleigh(1).
    ref = np.random.default_rng(99).rayleigh(1.0, 2_000_000)
    truth = {t: float(np.degrees(np.arctan(math.radians(s) * ref)).mean()) for t, s in sigma.items()}
    scores = {"contours": 0.9, "shaded": 0.3, "ridges": -0.2, "pel": -1.0}
    names = list(scores)
    for p in range(30):
        rows = []
        for t in sigma:  # gauge: 40 trials per technique, 2 models
            for k in range(40):
                n = rng.normal(size=3)
                n[2] = abs(n[2]) + 0.5
                n /= np.linalg.norm(n)
                m = rotate_noise(n, sigma[t], rng)
                rows.append({"task": "gauge", "technique": t, "model": "liver" if k % 2 else "aneurysm",
                             "true_nx": n[0], "true_ny": n[1], "true_nz": n[2],
                             "normal_x": m[0], "normal_y": m[1], "normal_z": m[2]})
        for _ in range(100):  # 2afc from Bradley-Terry scores
            i, j = rng.choice(len(names), 2, replace=False)
            a, b = names[i], names[j]
            pa = 1 / (1 + math.exp(-(scores[a] - scores[b])))
            c = 0 if rng.random() < pa else 1
            rows.append({"task": "2afc", "technique_a": a, "technique_b": b, "techniques": f"{a}|{b}",
                         "choice": c, "chosen_technique": (a, b)[c], "model": "liver"})
        noisy = sorted(names, key=lambda n: -(scores[n] + rng.normal(0, 0.3)))
        rows.append({"task": "ranking", "order": "|".join(noisy), "response": "|".join(noisy)})
        for t in names:
            rows.append({"task": "likert", "technique": t, "rating": int(np.clip(round(4 + 2 * scores[t] +
                                                                                   rng.normal()), 1, 7))})
        write_log(d, f"S{p:02d}", rows)
    rep = os.path.join(d, "report")
    r = study_bin("analyze", d, "-o", rep)
    check(r.returncode == 0, f"analyze: {r.stderr}")
    report = json.load(open(os.path.join(rep, "report.json")))
    g = report["gauge"]
    for t, v in truth.items():
        s = g["techniques"][t]
        check(s["ci95"][0] <= v <= s["ci95"][1], f"gauge {t}: true mean {v:.2f} outside CI {s['ci95']}")
        # Participant bootstrap: no participant effect here, so about as wide as the
        # trial bootstrap, around the mean (truth within 1.5 half-widths, ~99.7%).
        c, w = s["ci95_by_participant"], s["ci95"][1] - s["ci95"][0]
        check(c[0] < s["mean_error_deg"] < c[1] and 0.5 * w < c[1] - c[0] < 2 * w and
              abs(v - s["mean_error_deg"]) < 1.5 * (c[1] - c[0]) / 2,
              f"gauge {t}: participant-bootstrap CI {c} (trial CI {s['ci95']}, true {v:.2f})")
    check(g["order_best_first"] == ["contours", "shaded", "ridges"], f"gauge order {g['order_best_first']}")
    check("liver" in g["models"] and "contours" in g["models"]["liver"], "no per-model gauge summary")
    mm = g["mixed_model"]
    check("fixed_effects" in mm, f"mixed model failed: {mm}")
    fe = mm["fixed_effects"]
    check(fe["C(technique)[T.ridges]"]["estimate"] > fe["C(technique)[T.shaded]"]["estimate"] > 0,
          f"mixed model effects: {fe}")
    bt = report["2afc"]["bradley_terry"]
    for t, s in scores.items():
        check(bt[t]["ci95"][0] <= s <= bt[t]["ci95"][1], f"Bradley-Terry {t}: true {s} outside {bt[t]['ci95']}")
    check(report["2afc"]["order_best_first"] == names, f"2afc order {report['2afc']['order_best_first']}")
    check(sum(map(sum, report["2afc"]["win_matrix"]["wins"])) == 3000, "win matrix does not count 3000 trials")
    check(report["ranking"]["schulze_order"] == names, f"Schulze order {report['ranking']['schulze_order']}")
    lk = report["likert"]["techniques"]
    check(lk["contours"]["mean"] > lk["pel"]["mean"] and sum(lk["pel"]["counts"].values()) == 30, "likert")
    print("analysis: ok")


def main():
    global A
    ap = argparse.ArgumentParser()
    ap.add_argument("case", choices=["plan", "e2e", "stimuli", "analysis", "web"])
    ap.add_argument("--node", default="node")
    ap.add_argument("--study", required=True)
    ap.add_argument("--fabrica", required=True)
    ap.add_argument("--meshes", required=True)
    ap.add_argument("--work", required=True)
    A = ap.parse_args()
    os.makedirs(A.work, exist_ok=True)
    globals()["case_" + A.case]()


if __name__ == "__main__":
    main()

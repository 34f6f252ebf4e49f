#!/usr/bin/python3
"""fabrica-study analyze: the statistics of a study's response logs.

Usage: fabrica_study_analyze.py RESULTS_DIR -o REPORT_DIR

Reads every RESULTS_DIR/participants/*/responses.csv (the tidy log written
by `fabrica-study run`; docs/study.md), skips practice trials, reports
attention checks, and writes REPORT_DIR/report.json plus plots (PNG and
SVG). Written for study authors to read and extend: one function per task.

  gauge    angular error (degrees) between the response and the true view-space
           normal; per technique and per technique x model: mean, median and
           95% bootstrap CIs (percentile, 2000 resamples of trials, fixed seed;
           also resampling whole participants, ci95_by_participant);
           a linear mixed model error ~ technique with a random intercept per
           participant and a variance component for the model (statsmodels
           MixedLM).
  2afc     Bradley-Terry scores (log-strengths, centred to mean 0) by maximum
           likelihood, 95% CIs from the observed Fisher information; the win
           matrix (row beat column).
  likert   per technique: counts of each rating, mean, median.
  ranking  Schulze order from the pairwise preferences of all rankings.

Exit codes: 0 ok, 2 bad input (no logs, malformed CSV), 3 report not writable.
"""
import argparse
import glob
import json
import os
import sys

import numpy as np
import pandas as pd

SEED = 20090801  # bootstrap seed (fixed: the report is reproducible)
N_BOOT = 2000


def fail(code, message):
    print("fabrica-study analyze: " + message, file=sys.stderr)
    sys.exit(code)


def load(results_dir):
    files = sorted(glob.glob(os.path.join(results_dir, "participants", "*", "responses.csv")))
    if not files:
        fail(2, f"{results_dir}: no participants/*/responses.csv (is it a `fabrica-study run --out` folder?)")
    frames = []
    for f in files:
        try:
            d = pd.read_csv(f, dtype={"participant": str, "question": str, "response": str,
                                      "order": str, "expected": str})
        except Exception as e:  # noqa: BLE001 - any parse failure is bad input
            fail(2, f"{f}: cannot read the response log ({e})")
        if "trial" not in d.columns or "task" not in d.columns:
            fail(2, f"{f}: not a fabrica-study response log (no trial/task column)")
        frames.append(d)
    data = pd.concat(frames, ignore_index=True)
    # A trial answered twice (should not happen) counts once: the first answer.
    data = data.drop_duplicates(subset=["participant", "trial"], keep="first")
    return data


def bootstrap_ci(values, stat, rng):
    values = np.asarray(values, dtype=float)
    if len(values) < 2:
        v = float(stat(values)) if len(values) else float("nan")
        return [v, v]
    idx = rng.integers(0, len(values), size=(N_BOOT, len(values)))
    stats = np.array([stat(values[i]) for i in idx])
    return [float(np.percentile(stats, 2.5)), float(np.percentile(stats, 97.5))]


def cluster_ci(errors, participants, rng):
    """95% CI of the mean resampling whole participants (their trials are not independent)."""
    ids, inverse = np.unique(np.asarray(participants), return_inverse=True)
    if len(ids) < 3:
        return None
    sums = np.bincount(inverse, weights=errors)
    counts = np.bincount(inverse).astype(float)
    idx = rng.integers(0, len(ids), size=(N_BOOT, len(ids)))
    means = sums[idx].sum(axis=1) / counts[idx].sum(axis=1)
    return [float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))]


def summary(d, rng):
    errors = d["error_deg"].to_numpy()
    return {
        "n": int(len(errors)),
        "participants": int(d["participant"].nunique()),
        "mean_error_deg": float(np.mean(errors)),
        "ci95": bootstrap_ci(errors, np.mean, rng),
        "ci95_by_participant": cluster_ci(errors, d["participant"], rng),
        "median_error_deg": float(np.median(errors)),
        "median_ci95": bootstrap_ci(errors, np.median, rng),
    }


def angular_error(d):
    r = d[["normal_x", "normal_y", "normal_z"]].to_numpy(float)
    t = d[["true_nx", "true_ny", "true_nz"]].to_numpy(float)
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(r * t, axis=1), -1.0, 1.0)))


def mixed_model(g):
    """error ~ technique, random intercept per participant, model as a variance component."""
    import statsmodels.formula.api as smf
    out = {"formula": "error_deg ~ C(technique)", "groups": "participant",
           "variance_components": ["model"] if g["model"].nunique() > 1 else []}
    if g["participant"].nunique() < 2 or g["technique"].nunique() < 2:
        out["skipped"] = "needs at least two participants and two techniques"
        return out
    try:
        import warnings
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            vc = {"model": "0 + C(model)"} if g["model"].nunique() > 1 else None
            m = smf.mixedlm("error_deg ~ C(technique)", g, groups=g["participant"],
                            vc_formula=vc, re_formula="1")
            # BFGS first: L-BFGS returns a wrong intercept when the participant
            # variance sits on the boundary (0), as with few participants.
            fit = m.fit(reml=True, method=["bfgs", "powell"])
        out["converged"] = bool(fit.converged)
        out["warnings"] = sorted({str(w.message).splitlines()[0] for w in caught})
        out["fixed_effects"] = {
            name: {"estimate": float(fit.fe_params[name]), "se": float(fit.bse_fe[name]),
                   "p": float(fit.pvalues[name])}
            for name in fit.fe_params.index}
        out["participant_variance"] = float(fit.cov_re.iloc[0, 0])
        if vc:
            out["model_variance"] = float(fit.vcomp[0])
        out["residual_variance"] = float(fit.scale)
    except Exception as e:  # noqa: BLE001 - reported, not fatal
        out["error"] = str(e)
    return out


def analyze_gauge(data):
    g = data[(data.task == "gauge") & (data.practice == 0) & (data.attention == 0)].copy()
    if g.empty:
        return None, None
    g["error_deg"] = angular_error(g)
    rng = np.random.default_rng(SEED)
    report = {"techniques": {}, "models": {}}
    for t, d in sorted(g.groupby("technique"), key=lambda kv: kv[0]):
        report["techniques"][t] = summary(d, rng)
    for (t, m), d in sorted(g.groupby(["technique", "model"]), key=lambda kv: kv[0]):
        report["models"].setdefault(m, {})[t] = summary(d, rng)
    report["order_best_first"] = sorted(report["techniques"],
                                        key=lambda t: report["techniques"][t]["mean_error_deg"])
    report["mixed_model"] = mixed_model(g)
    return report, g


def bradley_terry(names, wins):
    """ML log-strengths (sum zero) and their standard errors. wins[i, j]: i beat j."""
    from scipy.optimize import minimize
    k = len(names)
    n = wins + wins.T

    def nll(beta_free):
        beta = np.concatenate([[0.0], beta_free])
        diff = beta[:, None] - beta[None, :]
        # -sum w_ij log sigma(b_i - b_j); ridge 1e-6 keeps perfect separation finite
        return float(np.sum(wins * np.logaddexp(0.0, -diff))) + 1e-6 * float(beta_free @ beta_free)

    res = minimize(nll, np.zeros(k - 1), method="BFGS")
    beta = np.concatenate([[0.0], res.x])
    # Observed information for the free parameters (analytic Hessian).
    p = 1.0 / (1.0 + np.exp(-(beta[:, None] - beta[None, :])))
    w = n * p * (1 - p)
    info = np.diag(w.sum(axis=1)) - w
    info_free = info[1:, 1:] + 2e-6 * np.eye(k - 1)
    cov_free = np.linalg.inv(info_free)
    cov = np.zeros((k, k))
    cov[1:, 1:] = cov_free
    centre = np.eye(k) - np.ones((k, k)) / k  # scores centred to mean 0
    scores = centre @ beta
    cov_s = centre @ cov @ centre.T
    se = np.sqrt(np.clip(np.diag(cov_s), 0, None))
    return scores, se


def analyze_2afc(data):
    a = data[(data.task == "2afc") & (data.practice == 0) & (data.attention == 0)]
    if a.empty:
        return None
    names = sorted(set(a["technique_a"]) | set(a["technique_b"]))
    index = {n: i for i, n in enumerate(names)}
    wins = np.zeros((len(names), len(names)))
    for _, r in a.iterrows():
        w = r["chosen_technique"]
        lose = r["technique_b"] if w == r["technique_a"] else r["technique_a"]
        wins[index[w], index[lose]] += 1
    scores, se = bradley_terry(names, wins)
    return {
        "n": int(len(a)),
        "bradley_terry": {n: {"score": float(scores[i]),
                              "se": float(se[i]),
                              "ci95": [float(scores[i] - 1.96 * se[i]), float(scores[i] + 1.96 * se[i])]}
                          for i, n in enumerate(names)},
        "order_best_first": [names[i] for i in np.argsort(-scores, kind="stable")],
        "win_matrix": {"techniques": names, "wins": wins.astype(int).tolist(),
                       "note": "wins[i][j]: times technique i was chosen over technique j"},
    }


def analyze_likert(data):
    lk = data[(data.task == "likert") & (data.practice == 0) & (data.attention == 0)]
    if lk.empty:
        return None
    out = {"techniques": {}}
    for t, d in sorted(lk.groupby("technique"), key=lambda kv: kv[0]):
        r = d["rating"].astype(int)
        counts = r.value_counts().sort_index()
        out["techniques"][t] = {"n": int(len(r)), "mean": float(r.mean()), "median": float(r.median()),
                                "counts": {str(int(k)): int(v) for k, v in counts.items()}}
    return out


def schulze(names, rankings):
    k = len(names)
    idx = {n: i for i, n in enumerate(names)}
    d = np.zeros((k, k), dtype=int)
    for order in rankings:
        pos = {t: i for i, t in enumerate(order)}
        for a in order:
            for b in order:
                if pos[a] < pos[b]:
                    d[idx[a], idx[b]] += 1
    p = np.where(d > d.T, d, 0)
    for i in range(k):
        for j in range(k):
            if i == j:
                continue
            for m in range(k):
                if m not in (i, j):
                    p[j, m] = max(p[j, m], min(p[j, i], p[i, m]))
    wins = [(sum(1 for j in range(k) if j != i and p[i, j] > p[j, i]), names[i]) for i in range(k)]
    order = [n for _, n in sorted(wins, key=lambda w: (-w[0], w[1]))]
    return order, d


def analyze_ranking(data):
    rk = data[(data.task == "ranking") & (data.practice == 0)]
    if rk.empty:
        return None
    rankings = [str(o).split("|") for o in rk["order"]]
    names = sorted({t for r in rankings for t in r})
    order, d = schulze(names, rankings)
    return {"n": int(len(rk)), "schulze_order": order,
            "pairwise": {"techniques": names, "preferred": d.tolist(),
                         "note": "preferred[i][j]: rankings placing i above j"}}


def attention(data):
    at = data[data.attention == 1]
    out = {}
    for p, d in at.groupby("participant"):
        passed = 0
        for _, r in d.iterrows():
            if r["task"] == "gauge":
                e = np.array([float(x) for x in str(r["expected"]).split()])
                n = np.array([r["normal_x"], r["normal_y"], r["normal_z"]], float)
                ok = np.degrees(np.arccos(np.clip(n @ e / np.linalg.norm(n), -1, 1))) <= 30
            else:
                ok = str(r["response"]).strip() == str(r["expected"]).strip()
            passed += int(ok)
        out[p] = {"checks": int(len(d)), "passed": passed}
    return out


def plots(report, gauge_rows, out_dir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    made = []

    def save(fig, name):
        for ext in ("png", "svg"):
            path = os.path.join(out_dir, f"{name}.{ext}")
            fig.savefig(path, dpi=120, bbox_inches="tight", metadata={"Date": None} if ext == "svg" else None)
            made.append(os.path.basename(path))
        plt.close(fig)

    def bars(names, values, lows, highs, ylabel, title, name):
        fig, ax = plt.subplots(figsize=(1.2 + 1.1 * len(names), 3.6))
        x = np.arange(len(names))
        ax.bar(x, values, color="#8aa8c8")
        ax.errorbar(x, values, yerr=[np.array(values) - lows, np.array(highs) - values],
                    fmt="none", ecolor="black", capsize=4)
        ax.set_xticks(x, names, rotation=20, ha="right")
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        save(fig, name)

    g = report.get("gauge")
    if g:
        names = list(g["techniques"])
        v = [g["techniques"][n]["mean_error_deg"] for n in names]
        bars(names, v, np.array([g["techniques"][n]["ci95"][0] for n in names]),
             np.array([g["techniques"][n]["ci95"][1] for n in names]),
             "mean angular error (deg)", "Gauge task (95% bootstrap CI)", "gauge_mean_error")
        fig, ax = plt.subplots(figsize=(1.2 + 1.1 * len(names), 3.6))
        ax.boxplot([gauge_rows[gauge_rows.technique == n]["error_deg"] for n in names], labels=names)
        ax.set_ylabel("angular error (deg)")
        ax.set_title("Gauge task: error distribution")
        plt.setp(ax.get_xticklabels(), rotation=20, ha="right")
        save(fig, "gauge_error_distribution")
    a = report.get("2afc")
    if a:
        bt = a["bradley_terry"]
        names = list(bt)
        bars(names, [bt[n]["score"] for n in names], np.array([bt[n]["ci95"][0] for n in names]),
             np.array([bt[n]["ci95"][1] for n in names]), "Bradley-Terry score",
             "Two-alternative forced choice (95% CI)", "2afc_bradley_terry")
    lk = report.get("likert")
    if lk:
        names = list(lk["techniques"])
        ks = sorted({int(k) for n in names for k in lk["techniques"][n]["counts"]})
        fig, ax = plt.subplots(figsize=(5, 0.8 + 0.5 * len(names)))
        left = np.zeros(len(names))
        cmap = plt.get_cmap("RdYlGn")
        for i, k in enumerate(ks):
            c = np.array([lk["techniques"][n]["counts"].get(str(k), 0) / lk["techniques"][n]["n"]
                          for n in names])
            ax.barh(names, c, left=left, color=cmap(i / max(1, len(ks) - 1)), label=str(k))
            left += c
        ax.set_xlabel("fraction of ratings")
        ax.legend(ncol=len(ks), fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.25))
        ax.set_title("Likert ratings")
        save(fig, "likert")
    return made


def finite(x):
    """NaN or infinity (e.g. an undefined p-value) become null: the report is valid JSON."""
    if isinstance(x, dict):
        return {k: finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [finite(v) for v in x]
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    ap.add_argument("-o", "--output", required=True)
    args = ap.parse_args()
    data = load(args.dir)
    for c in ("practice", "attention"):
        data[c] = data[c].fillna(0).astype(int)
    try:
        os.makedirs(args.output, exist_ok=True)
    except OSError as e:
        fail(3, f"{args.output}: cannot create the report folder ({e.strerror})")
    report = {"participants": sorted(data["participant"].unique().tolist()),
              "responses": int(len(data)),
              "attention_checks": attention(data)}
    gauge, gauge_rows = analyze_gauge(data)
    for key, value in (("gauge", gauge), ("2afc", analyze_2afc(data)),
                       ("likert", analyze_likert(data)), ("ranking", analyze_ranking(data))):
        if value is not None:
            report[key] = value
    report["plots"] = plots(report, gauge_rows, args.output)
    path = os.path.join(args.output, "report.json")
    tmp = path + ".tmp"
    try:
        with open(tmp, "w") as f:
            json.dump(finite(report), f, indent=2, allow_nan=False)
            f.write("\n")
        os.replace(tmp, path)
    except (OSError, ValueError) as e:
        fail(3, f"{path}: cannot write the report ({e})")
    print(f"fabrica-study analyze: {len(report['participants'])} participant(s), "
          f"{report['responses']} responses -> {path}", file=sys.stderr)


if __name__ == "__main__":
    main()

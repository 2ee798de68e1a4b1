#!/usr/bin/env python3
"""The reproduction page (docs/REPRODUCTION.md): every claim of the paper's evaluation, the
paper's figure (a citation of the RED paper, arXiv:2308.15368, labelled as the paper's) beside
ours, computed from the runs that bench/reproduce.sh made or reused. Writes
OUT/reproduction.md, OUT/reproduction.json and the gnuplot plots OUT/plots/*.svg.

    reproduce.py page OUT --mode real|reuse|quick [--command CMD] [--source DIR ...]
    reproduce.py check OUT      exit 1 unless every section is there and every number parses

OUT's layout (what bench/reproduce.sh leaves there):
    runs/<scenario>/run<k>/{summary.json,jobs.csv}   real runs (bench/fidelity.sh's layout;
                                                     in a smoke run, simulator seeds)
    table4/deadline_scale-<v>/run<k>/summary.json    Table 4 on real inference
    sim/table4/sweep.json, sim/table5/sweep.json     `red sweep` in the simulator (breadth)
    sim/ablation-nomerge/<scenario>/summary.json     red-fg without shared encoder runs
    profile.json                                     `red profile` (isolated units)
    grid.txt                                         `red_load_grid` output (optional)
"""
import argparse
import csv
import glob
import json
import math
import os
import platform
import re
import statistics
import subprocess
import sys
import time

from reproduce_plots import bars_with_spread, grouped_bars, lines

POLICIES = ["fifo", "mono", "edf", "red-fg", "red-ida", "red", "red-robust"]
PAPER_POLICIES = ["edf", "red-fg", "red-ida", "red"]
DEADLINE_SCALES = [0.75, 0.9, 1.05, 1.2, 1.35, 1.5]
LAMBDAS = [0.001, 0.01, 0.1, 1.0, 10.0]
INTERFERENCE = ["none", "low", "medium", "high"]
SECTIONS = ["fig6_tight", "fig6_loose", "table4", "table5", "ablation", "case1", "case2",
            "table1_overheads", "interference", "fidelity"]

# The paper's figures, cited from Li, Ren, He, Liu, "RED: A Systematic Real-Time Scheduling Approach for Robotic Environmental Dynamics", RTSS 2023, arXiv:2308.15368
# (sections "Evaluation" and "Motivational Case Study"). Percentages are the paper's "lower/higher by" figures.
PAPER = {
    # Fig. 6 (overall effectiveness), averages over four boards and both deadline settings.
    "fig6_miss_lower": {"edf": 40.5, "red-ida": 37.8, "red-fg": 37.5},
    "fig6_latency_lower": {"edf": 24.7, "red-ida": 17.3, "red-fg": 14.2},
    "fig6_qoe_higher": {"edf": 34.8, "red-ida": 34.2, "red-fg": 15.9},
    "fig6_qoe_higher_tight": {"edf": 76.4, "red-ida": 84.7, "red-fg": 40.4},
    "fig6_qoe_higher_loose": {"edf": 13.1, "red-ida": 9.8, "red-fg": 1.4},
    # Table 4 (Xavier): end-to-end latency (ms) per deadline setting 1..6.
    "table4_latency_ms": {
        "edf": [5869, 6807, 6865, 7760, 8737, 9694],
        "red-fg": [5883, 6006, 6803, 7856, 8723, 9688],
        "red-ida": [4950, 4929, 6691, 7465, 8313, 9045],
        "red": [4455, 4435, 4456, 4500, 5930, 6779]},
    "table4_latency_lower": {"edf": 23.2, "red-ida": 20.1, "red-fg": 17.1},
    # Table 5 (Xavier row): QoE per lambda 0.001, 0.01, 0.1, 1, 10.
    "table5_xavier": {
        "edf": [0.748, 0.746, 0.735, 0.616, 0.003],
        "red-fg": [0.525, 0.523, 0.501, 0.295, 0.005],
        "red-ida": [0.946, 0.945, 0.942, 0.902, 0.500],
        "red": [0.999, 0.999, 0.998, 0.996, 0.900]},
    # Case study 1: task B's miss and drop rate before, while and after detection joins.
    "case1_miss_pct": [3.3, 30.0, 2.2],
    # Table 1: MIMONet vs the four task models (params M, FLOPs G).
    "table1_params_m": {"mimonet": 10.465, "separate": 3.666 + 1.943 + 2.489 + 5.286},
    "table1_flops_g": {"mimonet": 6.704, "separate": 4.111 + 2.655 + 0.465 + 0.283},
    # Overheads: Tables 6 and 7.
    "runtime_overhead_ms": {"Nano": 27.3, "TX2": 26.9, "Xavier": 17.4, "Orin": 1.2},
    "profiling_s": {"Nano": 51.1, "TX2": 34.3, "Xavier": 19.1, "Orin": 16.1},
    "memory": {"scheduler_kb": [3, 5], "synchronization_mb": [36.9, 40.1]},
    # ROS 2 case study under GPU interference: RED vs EDF.
    "interference_miss_lower": 67.3,
    "interference_latency_lower": 32.7,
}


# ---------------------------------------------------------------- computations (tested)

def qoe_score(finish_ms, deadline_ms, lam):
    """docs/DESIGN.md, "Metrics" / the paper's Eq. 1: 1 / (1 + e^lambda * max(0, R - D)), in seconds.
    R - D = finish - absolute deadline."""
    late_s = max(0.0, (finish_ms - deadline_ms) / 1000.0)
    return 1.0 / (1.0 + math.exp(lam) * late_s)


def read_jobs(path):
    """jobs.csv -> {policy: [row dict]}."""
    out = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            out.setdefault(row["policy"], []).append(row)
    return out


def qoe_at(rows, lam):
    """Mean QoE of one policy's jobs.csv rows at lambda, as src/metrics/metrics.cpp counts it:
    completed jobs score, dropped/skipped/failed jobs score 0, unfinished jobs are left out.
    None when no job was decided."""
    total, n = 0.0, 0
    for r in rows:
        o = r["outcome"]
        if o == "unfinished":
            continue
        n += 1
        if o in ("met", "missed"):
            total += qoe_score(float(r["finish_ms"]), float(r["deadline_ms"]), lam)
    return total / n if n else None


def miss_pct(rows):
    """Miss rate (%) of jobs.csv rows: late or dropped over decided (docs/DESIGN.md, "Metrics")."""
    decided = [r for r in rows if r["outcome"] != "unfinished"]
    if not decided:
        return None
    return 100.0 * sum(r["outcome"] != "met" for r in decided) / len(decided)


def spread(values):
    """(median, min, max) of the values that are not None, or None."""
    v = [x for x in values if x is not None]
    if not v:
        return None
    return (statistics.median(v), min(v), max(v))


def cell(values, fmt="{:.2f}"):
    """'median [min–max]' of the values, or '—'; one value alone is printed as is."""
    s = spread(values)
    if s is None:
        return "—"
    if len([x for x in values if x is not None]) == 1:
        return fmt.format(s[0])
    return (fmt + " [" + fmt + "–" + fmt + "]").format(*s)


def lower_pct(ours, base):
    """How much lower ours is than base, in % of base (the paper's 'lower by')."""
    if ours is None or base is None or base <= 0:
        return None
    return (1.0 - ours / base) * 100.0


def higher_pct(ours, base):
    """How much higher ours is than base, in % of base."""
    if ours is None or base is None or base <= 0:
        return None
    return (ours / base - 1.0) * 100.0


def verdict(paper, ours):
    """The rule of the page: our improvement (same sign convention as the paper's) against
    the paper's. None -> not measured; <= 0 -> did not hold; >= the paper's -> held more
    strongly; else held, weaker."""
    if ours is None:
        return "not measured"
    if ours <= 0:
        return "did not hold"
    if ours >= paper:
        return "held more strongly"
    return "held, weaker"


def ordering(values, names):
    """Names sorted by value (None last), ties kept in the given order."""
    known = [n for n in names if values.get(n) is not None]
    return sorted(known, key=lambda n: values[n])


def bins_miss_pct(rows, bin_s):
    """Miss rate (%) per bin of release time (seconds from 0), for decided jobs."""
    per = {}
    for r in rows:
        if r["outcome"] == "unfinished":
            continue
        b = int(float(r["release_ms"]) / 1000.0 / bin_s)
        per.setdefault(b, []).append(r["outcome"] != "met")
    return [(b * bin_s, 100.0 * sum(v) / len(v)) for b, v in sorted(per.items())]


# ---------------------------------------------------------------- reading the runs

def run_dirs(d):
    """run<k> directories of d with a summary.json, in k order."""
    out = []
    for p in glob.glob(os.path.join(d, "run*", "summary.json")):
        m = re.fullmatch(r"run(\d+)", os.path.basename(os.path.dirname(p)))
        if m:
            out.append((int(m.group(1)), os.path.dirname(p)))
    return [p for _, p in sorted(out)]


def load_runs(d):
    """[(summary dict, run dir)] of every run in d."""
    return [(json.load(open(os.path.join(r, "summary.json"))), r) for r in run_dirs(d)]


def by_policy(runs):
    """{policy: [policy dict per run]} over the runs' summaries, in POLICIES order."""
    per = {}
    for s, _ in runs:
        for p in s["policies"]:
            per.setdefault(p["name"], []).append(p)
    order = [n for n in POLICIES if n in per] + [n for n in per if n not in POLICIES]
    return {n: per[n] for n in order}


def lat_mean(p):
    m = p["latency_ms"]["mean"]
    return m if m > 0 else None


def med(values):
    s = spread(values)
    return s[0] if s else None


def fmt_opt(x, f="{:.1f}"):
    return "—" if x is None else f.format(x)


# ---------------------------------------------------------------- sections

class Page:
    def __init__(self, out, mode):
        self.out = out
        self.mode = mode
        self.md = []
        self.data = {}
        self.plots = []
        self.summary = []  # (claim, paper, ours, verdict)

    def runs(self, scenario):
        return load_runs(os.path.join(self.out, "runs", scenario))

    def plot(self, path, alt):
        if path:
            self.plots.append(path)
            self.md += ["", f"![{alt}]({path})"]

    def table(self, header, rows):
        self.md += ["", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        self.md += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]

    def missing(self, key, what):
        self.md += ["", f"Not measured: {what}."]
        self.data[key] = {"measured": False, "why": what}


def runs_note(page, runs):
    loads = []
    for _, r in runs:
        f = r + ".load"
        if os.path.exists(f):
            loads.append(open(f).read().split()[0])
    kind = {r[0].get("backend", "?") for r in runs}
    note = f"{len(runs)} run(s), backend {', '.join(sorted(kind))}"
    if loads:
        note += f", 1-min load average {', '.join(loads)}"
    return note


def policy_table(page, per):
    rows = []
    for pol, ps in per.items():
        jobs = [p["jobs"] for p in ps]
        rows.append([pol, cell([100 * p["miss_rate"] for p in ps]),
                     cell([lat_mean(p) for p in ps], "{:.1f}"),
                     cell([p["latency_ms"]["p99"] if p["latency_ms"]["p99"] > 0 else None for p in ps],
                          "{:.1f}"),
                     cell([p["qoe"] for p in ps], "{:.3f}"),
                     cell([p["encoder_runs"] / j if j else None for p, j in zip(ps, jobs)], "{:.2f}"),
                     ", ".join(f"{p['sync_round_trips']}/{p['dispatches']}" for p in ps)])
    page.table(["policy", "miss %", "mean ms", "p99 ms", "QoE", "encoder runs / job",
                "round trips / dispatches (per run)"], rows)


def section_fig6(page, key, scenario, setting):
    page.md += ["", f"## Fig. 6, {setting} deadline ({scenario})"]
    runs = page.runs(scenario)
    if not runs:
        page.missing(key, f"no runs of {scenario}")
        for pol in ("edf", "red-ida", "red-fg"):
            page.summary.append((f"Fig. 6 {setting}: RED vs {pol.upper()}", "", "not measured",
                                 "not measured"))
        return
    per = by_policy(runs)
    page.md += ["", f"Every policy on the identical workload ({runs_note(page, runs)}); median "
                "[min–max] over runs. Mean latency is over completed jobs only (a policy that "
                "drops most jobs shows the latency of the few it finished)."]
    policy_table(page, per)
    medians = {pol: {"miss_pct": med([100 * p["miss_rate"] for p in ps]),
                     "mean_ms": med([lat_mean(p) for p in ps]),
                     "qoe": med([p["qoe"] for p in ps]),
                     "miss_range": [spread([100 * p["miss_rate"] for p in ps])[1],
                                    spread([100 * p["miss_rate"] for p in ps])[2]]}
               for pol, ps in per.items()}
    red = medians.get("red")
    rel_rows, rel = [], {}
    qoe_paper = PAPER["fig6_qoe_higher_" + setting]
    for base in ("edf", "red-ida", "red-fg"):
        b = medians.get(base)
        if not red or not b:
            continue
        m = lower_pct(red["miss_pct"], b["miss_pct"])
        both_zero = red["miss_pct"] == 0 and b["miss_pct"] == 0
        m_verdict = "both 0 %: nothing to gain" if both_zero else \
            verdict(PAPER["fig6_miss_lower"][base], m)
        lat = lower_pct(red["mean_ms"], b["mean_ms"])
        q = higher_pct(red["qoe"], b["qoe"])
        rel[base] = {"miss_lower_pct": m, "latency_lower_pct": lat, "qoe_higher_pct": q}
        rel_rows.append([f"RED vs {base}",
                         f"{PAPER['fig6_miss_lower'][base]} % lower",
                         "both 0" if both_zero else fmt_opt(m) + " % lower", m_verdict,
                         f"{PAPER['fig6_latency_lower'][base]} % lower", fmt_opt(lat) + " % lower",
                         verdict(PAPER["fig6_latency_lower"][base], lat),
                         f"{qoe_paper[base]} % higher", fmt_opt(q) + " % higher",
                         verdict(qoe_paper[base], q)])
        page.summary.append((f"Fig. 6 {setting}: RED vs {base.upper()} (miss / latency / QoE)",
                             f"{PAPER['fig6_miss_lower'][base]} / {PAPER['fig6_latency_lower'][base]}"
                             f" / {qoe_paper[base]} % better",
                             f"{'both 0' if both_zero else fmt_opt(m)} / {fmt_opt(lat)} / "
                             f"{fmt_opt(q)} % better",
                             " / ".join([m_verdict] + [verdict(p, o) for p, o in (
                                 (PAPER["fig6_latency_lower"][base], lat), (qoe_paper[base], q))])))
    page.md += ["", "RED against the paper's baselines, on the medians (the paper's figures: miss "
                "rate and latency averaged over four Jetson boards and both settings; QoE for the "
                f"{setting} setting). Verdict rule: ours ≤ 0 did not hold; ≥ the paper's held more "
                "strongly; else held, weaker."]
    page.table(["pair", "paper miss", "ours miss", "verdict", "paper latency", "ours latency",
                "verdict", "paper QoE", "ours QoE", "verdict"], rel_rows)
    knife = [pol for pol, m in medians.items() if m["miss_range"][1] - m["miss_range"][0] > 20]
    if knife:
        page.md += ["", "Spread over runs above 20 points (bimodal, a policy on a knife edge; "
                    "read the range, not the median): " + ", ".join(knife) + "."]
    page.plot(bars_with_spread(page.out, key, f"Fig. 6 {setting} ({scenario})", per),
              f"Fig. 6 {setting}")
    page.data[key] = {"measured": True, "scenario": scenario, "runs": len(runs),
                      "backend": runs[0][0].get("backend"), "medians": medians,
                      "red_vs": rel, "bimodal": knife}


def section_table4(page):
    page.md += ["", "## Table 4: deadline sweep over six settings"]
    page.md += ["", "The paper's six settings (IDs 1–6, tight to loose, on Xavier) map to "
                "`deadline_scale` " + ", ".join(f"{v:g}" for v in DEADLINE_SCALES) +
                " of `minibench-tight` (its deadline 1.125 × the coarse critical path; 1.5 × 1.125 "
                "is past the loose setting's 1.5). Cells: mean latency ms, median [min–max] over "
                "runs (completed jobs), then miss %."]
    real = {}
    for v in DEADLINE_SCALES:
        runs = load_runs(os.path.join(page.out, "table4", f"deadline_scale-{v:g}"))
        if runs:
            real[v] = by_policy(runs)
    data = {"real": None, "sim": None}
    if real:
        nruns = max(len(next(iter(r.values()))) for r in real.values())
        backend = load_runs(os.path.join(page.out, "table4",
                                         f"deadline_scale-{next(iter(real)):g}"))[0][0]["backend"]
        page.md += ["", f"**Measured** (backend {backend}, up to {nruns} run(s) per setting; "
                    "`red compare --set deadline_scale=V`):"]
        rows, series, lat_meds = [], [], {}
        for pol in PAPER_POLICIES:
            cells, ys = [], []
            for v in DEADLINE_SCALES:
                ps = real.get(v, {}).get(pol, [])
                lat = [lat_mean(p) for p in ps]
                cells.append(cell(lat, "{:.1f}") + " / " + cell([100 * p["miss_rate"] for p in ps], "{:.1f}") + " %")
                ys.append(med(lat))
            rows.append([pol] + cells)
            rows.append([f"{pol} (paper, ms)"] + [str(x) for x in PAPER["table4_latency_ms"][pol]])
            series.append((pol, ys))
            lat_meds[pol] = ys
        page.table(["policy"] + [f"{i + 1} (×{v:g})" for i, v in enumerate(DEADLINE_SCALES)], rows)
        rel = {}
        for base in ("edf", "red-ida", "red-fg"):
            vals = [lower_pct(r, b) for r, b in zip(lat_meds["red"], lat_meds[base])
                    if r is not None and b is not None]
            rel[base] = statistics.mean(vals) if vals else None
            page.summary.append((f"Table 4: RED's latency vs {base.upper()}, mean over settings",
                                 f"{PAPER['table4_latency_lower'][base]} % lower",
                                 fmt_opt(rel[base]) + " % lower",
                                 verdict(PAPER["table4_latency_lower"][base], rel[base])))
        page.md += ["", "RED's mean latency below each baseline, averaged over the six settings: " +
                    "; ".join(f"{b}: ours {fmt_opt(rel[b])} %, paper {PAPER['table4_latency_lower'][b]} %"
                              for b in rel) + "."]
        page.plot(lines(page.out, "table4", "Table 4: mean latency by deadline setting (measured)",
                        "deadline setting", "mean latency (ms)", list(range(1, 7)), series),
                  "Table 4 measured")
        data["real"] = {"latency_ms_median": lat_meds, "red_latency_lower_pct": rel}
    else:
        page.md += ["", "**Measured:** not in these runs (bench/reproduce.sh without `--reuse` "
                    "runs them; a reused directory needs `table4/deadline_scale-V/run*`)."]
        for base in ("edf", "red-ida", "red-fg"):
            page.summary.append((f"Table 4: RED's latency vs {base.upper()}, mean over settings",
                                 f"{PAPER['table4_latency_lower'][base]} % lower", "not measured",
                                 "not measured"))
    sweep = os.path.join(page.out, "sim", "table4", "sweep.json")
    if os.path.exists(sweep):
        sw = json.load(open(sweep))
        page.md += ["", "**Simulator, for breadth** (`red sweep … --set deadline_scale=…`, one "
                    "seed, the profile named in the command; not a measurement): miss % / mean ms"]
        rows = []
        for p in sw["policies"]:
            rows.append([p["name"]] + [f"{100 * m:.1f} / {l:.1f}" for m, l in
                                       zip(p["miss_rate"], p["latency_mean_ms"])])
        page.table(["policy"] + [f"×{v:g}" for v in sw["values"]], rows)
        data["sim"] = {"values": sw["values"],
                       "policies": {p["name"]: {"miss_rate": p["miss_rate"],
                                                "latency_mean_ms": p["latency_mean_ms"]}
                                    for p in sw["policies"]}}
    page.data["table4"] = data


def section_table5(page):
    page.md += ["", "## Table 5: QoE for λ from 0.001 to 10"]
    page.md += ["", "λ only changes the QoE metric (src/metrics/metrics.cpp `qoe_score`), not the "
                "schedule, so the QoE of each λ is recomputed from the tight runs' jobs.csv "
                "(QoE = 1 / (1 + e^λ · max(0, R − D)), dropped jobs 0). Under the strict drop of "
                "`edf` and the RED presets a late job is aborted at its deadline, so almost no job "
                "completes late and their QoE hardly moves with λ; in the paper late jobs "
                "completed and QoE fell with λ."]
    runs = page.runs("minibench-tight")
    jobs = [os.path.join(r, "jobs.csv") for _, r in runs if os.path.exists(os.path.join(r, "jobs.csv"))]
    if not jobs:
        page.missing("table5", "no jobs.csv of minibench-tight")
        page.summary.append(("Table 5: RED's QoE best at every λ", "yes (4 boards)", "not measured",
                             "not measured"))
        return
    per_run = [read_jobs(j) for j in jobs]
    pols = [p for p in POLICIES if any(p in r for r in per_run)]
    q = {pol: [[qoe_at(r[pol], lam) for r in per_run if pol in r] for lam in LAMBDAS] for pol in pols}
    # Consistency: lambda = 1 recomputed against the runs' own QoE.
    worst = 0.0
    for (s, _), r in zip([x for x in runs if os.path.exists(os.path.join(x[1], "jobs.csv"))], per_run):
        for p in s["policies"]:
            if p["name"] in r:
                got = qoe_at(r[p["name"]], 1.0)
                if got is not None:
                    worst = max(worst, abs(got - p["qoe"]))
    rows = []
    for pol in pols:
        rows.append([pol] + [cell(v, "{:.3f}") for v in q[pol]])
        if pol in PAPER["table5_xavier"]:
            rows.append([f"{pol} (paper, Xavier)"] + [f"{x:.3f}" for x in PAPER["table5_xavier"][pol]])
    page.md += ["", f"Measured ({len(jobs)} run(s) of minibench-tight, median [min–max]); λ = 1 "
                f"recomputed matches the runs' own QoE within {worst:.6f}."]
    page.table(["policy"] + [f"λ={lam:g}" for lam in LAMBDAS], rows)
    best = []
    for i, lam in enumerate(LAMBDAS):
        m = {pol: med(q[pol][i]) for pol in PAPER_POLICIES if pol in q}
        top = max(m.values()) if m else None
        best.append(top is not None and m.get("red") is not None and m["red"] >= top - 1e-9)
    held = all(best) if best else None
    page.summary.append(("Table 5: RED's QoE best of the paper's four at every λ",
                         "yes (4 boards)", "yes" if held else f"at {sum(best)} of {len(best)} λ",
                         "held" if held else "did not hold"))
    page.plot(lines(page.out, "table5", "Table 5: QoE by λ (median over runs)", "λ", "QoE", LAMBDAS,
                    [(pol, [med(v) for v in q[pol]]) for pol in pols], logx=True), "Table 5")
    data = {"measured": True, "lambdas": LAMBDAS,
            "qoe_median": {pol: [med(v) for v in q[pol]] for pol in pols},
            "lambda1_max_abs_diff": worst, "red_best_at": best}
    sweep = os.path.join(page.out, "sim", "table5", "sweep.json")
    if os.path.exists(sweep):
        sw = json.load(open(sweep))
        page.md += ["", "Simulator, for breadth (`red sweep … --set qoe_lambda=…`): QoE"]
        page.table(["policy"] + [f"λ={v:g}" for v in sw["values"]],
                   [[p["name"]] + [f"{x:.3f}" for x in p["qoe"]] for p in sw["policies"]])
        data["sim"] = {p["name"]: p["qoe"] for p in sw["policies"]}
    page.data["table5"] = data


def section_ablation(page):
    page.md += ["", "## Ablation: RED < RED-IDA < RED-FG < EDF, and which mechanism carries the gain"]
    data = {}
    any_runs = False
    for scen in ("minibench-tight", "minibench-loose"):
        runs = page.runs(scen)
        if not runs:
            continue
        any_runs = True
        per = by_policy(runs)
        miss = {p: med([100 * x["miss_rate"] for x in per[p]]) for p in PAPER_POLICIES if p in per}
        lat = {p: med([lat_mean(x) for x in per[p]]) for p in PAPER_POLICIES if p in per}
        enc = {p: med([x["encoder_runs"] / x["jobs"] for x in per[p] if x["jobs"]]) for p in PAPER_POLICIES if p in per}
        rt = {p: med([x["sync_round_trips"] / x["dispatches"] for x in per[p] if x["dispatches"]])
              for p in PAPER_POLICIES if p in per}
        order = ordering(miss, ["red", "red-ida", "red-fg", "edf"])
        expected = [p for p in ["red", "red-ida", "red-fg", "edf"] if p in miss]
        strict = order == expected and len(set(miss[p] for p in order)) == len(order)
        steps = []
        names = {("edf", "red-fg"): "fine graph + shared encoder runs (DynamicMerge)",
                 ("red-fg", "red-ida"): "deadline re-assignment (IDA)",
                 ("red-ida", "red"): "batching + on-demand synchronization"}
        for a, b in names:
            if a in miss and b in miss:
                steps.append([f"{a} → {b}", names[(a, b)],
                              fmt_opt(None if miss[a] is None or miss[b] is None else miss[b] - miss[a], "{:+.1f}"),
                              fmt_opt(None if lat[a] is None or lat[b] is None else (lat[b] - lat[a]) / lat[a] * 100, "{:+.1f}"),
                              f"{fmt_opt(enc[a], '{:.2f}')} → {fmt_opt(enc[b], '{:.2f}')}",
                              f"{fmt_opt(rt[a], '{:.2f}')} → {fmt_opt(rt[b], '{:.2f}')}"])
        page.md += ["", f"**{scen}** (medians of the Fig. 6 runs): order by miss rate "
                    + " < ".join(f"{p} {miss[p]:.1f} %" for p in order) +
                    (" — the paper's order, strictly." if strict else " — not the paper's strict order.")]
        page.table(["step", "mechanism added", "Δ miss pts", "Δ mean latency %",
                    "encoder runs / job", "round trips / dispatch"], steps)
        data[scen] = {"miss_pct": miss, "mean_ms": lat, "order": order, "paper_order": strict,
                      "encoder_runs_per_job": enc, "round_trips_per_dispatch": rt}
        nomerge = os.path.join(page.out, "sim", "ablation-nomerge", scen, "summary.json")
        if os.path.exists(nomerge):
            s = json.load(open(nomerge))
            p = next((x for x in s["policies"] if x["name"] == "red-fg"), None)
            if p:
                page.md += ["", f"Simulator, {scen}: `red-fg --with merge=no` (the fine graph without "
                            f"shared encoder runs): miss {100 * p['miss_rate']:.1f} %, mean "
                            f"{p['latency_ms']['mean']:.1f} ms, {p['encoder_runs'] / max(1, p['jobs']):.2f} "
                            "encoder runs per job — what the fine graph gives without sharing."]
                data[scen]["sim_red_fg_no_merge"] = {"miss_pct": 100 * p["miss_rate"],
                                                    "mean_ms": p["latency_ms"]["mean"]}
    if not any_runs:
        page.missing("ablation", "no Fig. 6 runs")
        page.summary.append(("Ablation order RED < RED-IDA < RED-FG < EDF", "held", "not measured",
                             "not measured"))
        return
    held = [s for s, d in data.items() if d["paper_order"]]
    page.summary.append(("Ablation order RED < RED-IDA < RED-FG < EDF (miss rate)", "held",
                         f"strictly on {len(held)} of {len(data)} settings",
                         "held" if len(held) == len(data) else "partly held"))
    grid = os.path.join(page.out, "grid.txt")
    if os.path.exists(grid):
        rows = [l for l in open(grid).read().splitlines() if l.startswith("|")]
        page.md += ["", "Random DAG task sets (`red_load_grid`, simulator, built-in default profile; "
                    "on-time fraction per family and load):", ""] + rows
        data["grid_rows"] = len(rows)
    else:
        page.md += ["", "Random DAG task sets: `red_load_grid` not built here (RED_BUILD_BENCH=ON); "
                    "see docs/BENCHMARKS.md, \"Overload\"."]
    page.data["ablation"] = {"measured": True, **data}


def section_case1(page):
    page.md += ["", "## Case study 1: object detection joins (case-dynamic)"]
    runs = page.runs("case-dynamic")
    if not runs:
        page.missing("case1", "no runs of case-dynamic")
        page.summary.append(("Case study 1: misses rise while detection is in", "3.3 → 30 → 2.2 %",
                             "not measured", "not measured"))
        return
    per = by_policy(runs)
    names = ["before", "while", "after"]
    rows, plot_rows, meds = [], [], {}
    for pol, ps in per.items():
        phases = [p.get("phases", []) for p in ps]
        n = min(len(x) for x in phases)
        vals = [[100 * x[i]["miss_rate"] for x in phases] for i in range(min(n, 3))]
        meds[pol] = [med(v) for v in vals]
        rows.append([pol] + [cell(v, "{:.1f}") for v in vals])
        plot_rows.append((pol, meds[pol] + [None] * (3 - len(meds[pol]))))
    rows.append(["paper (task B, Nano)"] + [f"{x}" for x in PAPER["case1_miss_pct"]])
    page.md += ["", f"Miss % per phase (jobs by release time; {runs_note(page, runs)}), median "
                "[min–max] over runs; phases start at the warm-up's end, 3 s and 6 s."]
    page.table(["policy", "before (to 3 s)", "while (3–6 s)", "after (from 6 s)"], rows)
    # A rise: at least 5 points above both other phases (a saturated 97 -> 100 -> 99 is none).
    rise = [pol for pol, m in meds.items()
            if len(m) == 3 and None not in m and m[1] >= max(m[0], m[2]) + 5]
    wide = [pol for pol, ps in per.items()
            if any((lambda s: s and s[2] - s[1] > 20)(spread([100 * x["phases"][i]["miss_rate"]
                                                            for x in ps if len(x.get("phases", [])) > i]))
                   for i in range(3))]
    page.md += ["", "Policies whose misses rise while detection is in (≥ 5 points above both other "
                "phases, on the medians; the paper's observation): " +
                (", ".join(rise) if rise else "none") + "."]
    if wide:
        page.md += ["", "Spread over runs above 20 points in some phase (bimodal: read the range): " +
                    ", ".join(wide) + "."]
    page.summary.append(("Case study 1: misses rise while detection is in", "3.3 → 30 → 2.2 %",
                         "; ".join(f"{p} " + " → ".join(fmt_opt(x) for x in meds[p])
                                   for p in ("edf", "red") if p in meds) + " %",
                         f"rise seen for {', '.join(rise)}" if rise else "no rise"))
    page.plot(grouped_bars(page.out, "case1", "Case study 1: miss % per phase", "miss %", names,
                           plot_rows), "case study 1")
    page.data["case1"] = {"measured": True, "miss_pct_median": meds, "rise": rise}


def section_case2(page):
    page.md += ["", "## Case study 2: asynchronous 30 Hz and 33 Hz tasks (case-async, case-async-dep)"]
    data = {"measured": False}
    rows, series, xs = [], [], None
    for scen in ("case-async", "case-async-dep"):
        runs = page.runs(scen)
        if not runs:
            continue
        data["measured"] = True
        per_run = [read_jobs(os.path.join(r, "jobs.csv")) for _, r in runs
                   if os.path.exists(os.path.join(r, "jobs.csv"))]
        data[scen] = {}
        for pol in [p for p in POLICIES if any(p in r for r in per_run)]:
            ops = sorted({row["operation"] for r in per_run for row in r.get(pol, [])})
            cells = []
            for op in ops:
                v = [miss_pct([x for x in r.get(pol, []) if x["operation"] == op]) for r in per_run]
                cells.append(f"{op} {cell(v, '{:.1f}')}")
                data[scen].setdefault(pol, {})[op] = med(v)
            rows.append([scen, pol, "; ".join(cells)])
        if per_run and "red" in per_run[0]:
            b = bins_miss_pct([x for x in per_run[0]["red"]], 0.5)
            xs = xs or [t for t, _ in b]
            ys = dict(b)
            series.append((f"red_{scen}", [ys.get(t) for t in xs]))
            data[scen]["red_bins_miss_pct_range"] = [min(v for _, v in b), max(v for _, v in b)] if b else None
    if not data["measured"]:
        page.missing("case2", "no runs of case-async or case-async-dep")
        page.summary.append(("Case study 2: the dependency degrades the 30/33 Hz pair",
                             "periodic degradation", "not measured", "not measured"))
        return
    page.md += ["", "Miss % per operation, median [min–max] over runs. The paper (qualitative): "
                "without the dependency both tasks behave uniformly; with B depending on A's "
                "newest output misses rise, periodically (the 30/33 Hz beat)."]
    page.table(["scenario", "policy", "miss % per operation"], rows)
    every = [v for scen in ("case-async", "case-async-dep") for pol in data.get(scen, {}).values()
             if isinstance(pol, dict) for v in pol.values()]
    data["all_missed"] = bool(every) and all(v is not None and v >= 99.999 for v in every)
    if data["all_missed"]:
        page.md += ["", "Every policy missed every job in both scenarios: the 30 ms deadline is "
                    "shorter than one job's work on this machine, so the dependency's effect cannot "
                    "show here (try `--set deadline_scale=…`)."]
    if series:
        page.plot(lines(page.out, "case2", "Case study 2: miss % of red per 0.5 s (first run)",
                        "release time (s)", "miss %", xs, series), "case study 2")
    sim_rows = []
    for scen in ("case-async", "case-async-dep"):
        f = os.path.join(page.out, "sim", "case2-x2", scen, "jobs.csv")
        if not os.path.exists(f):
            continue
        jobs = read_jobs(f)
        for pol, rs in jobs.items():
            ops_ = sorted({r["operation"] for r in rs})
            v = {op: miss_pct([r for r in rs if r["operation"] == op]) for op in ops_}
            data.setdefault("sim_deadline_x2", {}).setdefault(scen, {})[pol] = v
            sim_rows.append([scen, pol, "; ".join(f"{op} {fmt_opt(x)}" for op, x in v.items())])
    if sim_rows:
        page.md += ["", "Simulator, for breadth, with the deadline doubled (`--set deadline_scale=2`, "
                    "one seed, the scenario's calibrated profile when there is one): miss % per operation"]
        page.table(["scenario", "policy", "miss % per operation"], sim_rows)

    def ops(scen):
        v = data.get(scen, {}).get("red")
        return ", ".join(f"{k} {fmt_opt(x)} %" for k, x in v.items()) if v else "not measured"
    ours = f"red without: {ops('case-async')}; with: {ops('case-async-dep')}"
    page.summary.append(("Case study 2: the dependency degrades the 30/33 Hz pair",
                         "more misses with the dependency", ours,
                         "not testable here (every job missed)" if data["all_missed"] else "see section"))
    page.data["case2"] = data


def section_table1(page):
    page.md += ["", "## Table 1 and overheads"]
    prof = os.path.join(page.out, "profile.json")
    data = {"measured": False}
    if os.path.exists(prof):
        p = json.load(open(prof))
        u = p.get("units", {})

        def mean_ms(name):
            rows = [r for r in u.get(name, []) if r.get("batch") == 1]
            return rows[0]["mean_us"] / 1000.0 if rows else None
        heads = sorted(k.split("/", 1)[1] for k in u if k.startswith("head/"))
        shared = mean_ms("encoder")
        shared = None if shared is None or any(mean_ms("head/" + h) is None for h in heads) else \
            shared + sum(mean_ms("head/" + h) for h in heads)
        sep = [mean_ms("separate/" + h) for h in heads]
        separate = None if not sep or None in sep else sum(sep)
        mem = p.get("memory", {})

        def mb(kind, field):
            v = mem.get(kind, {}).get(field)
            return v / 1e6 if v is not None else None
        sm = (mb("shared", "parameter_bytes") or 0) + (mb("shared", "peak_activation_bytes") or 0)
        xm = (mb("separate", "parameter_bytes") or 0) + (mb("separate", "peak_activation_bytes") or 0)
        page.md += ["", f"From `red profile` ({p.get('source', '?')}, {p.get('device', '?')}, "
                    f"{p.get('model', '?')}): one frame through {len(heads)} heads, batch 1, mean. "
                    "FLOPs are not measured here (no FLOP counter in the profiler)."]
        page.table(["", "ours: shared MIMONet", "ours: separate networks", "ours: ratio",
                    "paper: MIMONet", "paper: four models"],
                   [["time ms", fmt_opt(shared, "{:.2f}"), fmt_opt(separate, "{:.2f}"),
                     fmt_opt(None if not shared or not separate else separate / shared, "{:.2f}×"),
                     "—", "—"],
                    ["parameters MB", fmt_opt(mb("shared", "parameter_bytes")),
                     fmt_opt(mb("separate", "parameter_bytes")),
                     fmt_opt(None if not xm else (mb("shared", "parameter_bytes") or 0) /
                             (mb("separate", "parameter_bytes") or 1), "{:.2f}×"),
                     f"{PAPER['table1_params_m']['mimonet']} M params",
                     f"{PAPER['table1_params_m']['separate']:.3f} M params (ratio "
                     f"{PAPER['table1_params_m']['mimonet'] / PAPER['table1_params_m']['separate']:.2f}×)"],
                    ["parameters + peak activations MB", fmt_opt(sm), fmt_opt(xm),
                     fmt_opt(sm / xm if xm else None, "{:.2f}×"), "—", "—"],
                    ["resident MB", fmt_opt(mb("shared", "resident_bytes")),
                     fmt_opt(mb("separate", "resident_bytes")), "—", "3739 MB (x86)",
                     "3752–3864 MB each (x86)"],
                    ["FLOPs", "not measured", "not measured", "—",
                     f"{PAPER['table1_flops_g']['mimonet']} G",
                     f"{PAPER['table1_flops_g']['separate']:.3f} G"]])
        data = {"measured": True, "frame_ms": {"shared": shared, "separate": separate},
                "memory_mb": {"shared": sm, "separate": xm},
                "profile_wall_s": p.get("profile_wall_s"),
                "sync_round_trip_us": p.get("sync_round_trip_us")}
        page.summary.append(("Table 1: one MIMONet vs separate networks",
                             "less memory (10.5 M vs 13.4 M params)",
                             f"{fmt_opt(separate / shared if shared and separate else None, '{:.2f}')}× "
                             f"faster, {fmt_opt(sm / xm if xm else None, '{:.2f}')}× memory",
                             "held" if shared and separate and xm and separate > shared and sm < xm
                             else "did not hold"))
    else:
        page.md += ["", "Table 1: no `red profile` output here (needs the LibTorch build; "
                    "`bench/reproduce.sh --profile F.json` names one)."]
        page.summary.append(("Table 1: one MIMONet vs separate networks", "less memory",
                             "not measured", "not measured"))
    # Overheads from the runtime reports of the real runs.
    rows, over = [], {}
    for scen in ("minibench-tight", "minibench-loose"):
        runs = page.runs(scen)
        for pol, ps in by_policy(runs).items():
            d = [p.get("decision_us") for p in ps if p.get("decision_us")]
            rss = [p.get("peak_rss_mb") for p in ps if p.get("peak_rss_mb")]
            if not d:
                continue
            over.setdefault(scen, {})[pol] = {"decision_p50_us": med([x["p50"] for x in d]),
                                              "decision_p99_us": med([x["p99"] for x in d])}
            rows.append([scen, pol, cell([x["p50"] for x in d]), cell([x["p99"] for x in d]),
                         cell(rss, "{:.1f}")])
    cal = None
    tight_prof = os.path.join(page.out, "runs", "minibench-tight", "profile.json")
    if os.path.exists(tight_prof):
        cal = json.load(open(tight_prof)).get("calibration", {}).get("handoff_us")
    page.md += ["", "Runtime overhead (real runs' runtime reports): scheduler decision time per "
                "decision, process peak resident set (model included). The paper: runtime "
                "overhead " + ", ".join(f"{k} {v} ms" for k, v in PAPER["runtime_overhead_ms"].items()) +
                f"; scheduler memory {PAPER['memory']['scheduler_kb'][0]}–"
                f"{PAPER['memory']['scheduler_kb'][1]} KB, synchronization "
                f"{PAPER['memory']['synchronization_mb'][0]}–{PAPER['memory']['synchronization_mb'][1]} MB."]
    if rows:
        page.table(["scenario", "policy", "decision p50 μs", "decision p99 μs", "peak RSS MB"], rows)
    else:
        page.md += ["", "No decision times in these runs (the simulator does not time decisions)."]
    page.md += ["", f"Hand-off (completion → next start), from the calibration: "
                f"{fmt_opt(cal, '{:.1f}')} μs; synchronization round trip measured by the profiler: "
                f"{fmt_opt(data.get('sync_round_trip_us'), '{:.1f}')} μs. RED's own memory beside "
                "the model is not recorded in a run's outputs: `bench/memory.sh` measures it "
                "(docs/BENCHMARKS.md, \"Memory of a real run\")."]
    page.md += ["", f"Profiling time: {fmt_opt(data.get('profile_wall_s'), '{:.1f}')} s (paper: " +
                ", ".join(f"{k} {v} s" for k, v in PAPER["profiling_s"].items()) + ")."]
    red_d = [v["red"]["decision_p99_us"] for v in over.values() if "red" in v]
    if red_d:
        page.summary.append(("Runtime overhead (RED's scheduler decision)", "1.2–27.3 ms",
                             f"p99 {max(red_d):.1f} μs", "held more strongly"))
    else:
        page.summary.append(("Runtime overhead (RED's scheduler decision)", "1.2–27.3 ms",
                             "not measured", "not measured"))
    if data.get("profile_wall_s") is not None:
        page.summary.append(("Profiling time", "16.1–51.1 s", f"{data['profile_wall_s']:.1f} s",
                             "held" if data["profile_wall_s"] <= 51.1 else "did not hold"))
    data["overheads"] = over
    data["handoff_us"] = cal
    page.data["table1_overheads"] = data


def section_interference(page):
    page.md += ["", "## Interference: none / low / medium / high background load"]
    rows, plot_rows, data = [], [], {}
    for lvl in INTERFERENCE:
        scen = f"interference-{lvl}"
        runs = page.runs(scen)
        if not runs:
            rows.append([lvl, "not measured", "", "", ""])
            continue
        per = by_policy(runs)
        miss = {p: med([100 * x["miss_rate"] for x in ps]) for p, ps in per.items()}
        lat = {p: med([lat_mean(x) for x in ps]) for p, ps in per.items()}
        m = lower_pct(miss.get("red"), miss.get("edf"))
        l = lower_pct(lat.get("red"), lat.get("edf"))
        data[lvl] = {"runs": len(runs), "miss_pct": miss, "mean_ms": lat,
                     "red_miss_lower_pct": m, "red_latency_lower_pct": l}
        both_zero = miss.get("red") == 0 and miss.get("edf") == 0
        data[lvl]["both_zero"] = both_zero
        rows.append([lvl, str(len(runs)),
                     "; ".join(f"{p} {cell([100 * x['miss_rate'] for x in ps], '{:.1f}')}" for p, ps in per.items()),
                     "both 0" if both_zero else fmt_opt(m), fmt_opt(l)])
        plot_rows.append((lvl, [miss.get(p) for p in POLICIES]))
    page.md += ["", "`interference-*.yaml`: background CPU load of rising intensity beside the "
                "run (the paper's ROS 2 case study used GPU interference on Xavier). Miss % "
                "median [min–max] over runs; RED against EDF on the medians (paper: "
                f"{PAPER['interference_miss_lower']} % fewer misses, "
                f"{PAPER['interference_latency_lower']} % lower response time). EDF's latency "
                "is over its completed jobs (— when it completes none)."]
    page.table(["level", "runs", "miss % per policy", "RED miss lower than EDF %",
                "RED latency lower than EDF %"], rows)
    if not data:
        page.missing("interference", "no runs of interference-*")
        page.summary.append(("Interference: RED ahead of EDF", "67.3 % fewer misses",
                             "not measured", "not measured"))
        return
    ms = [d["red_miss_lower_pct"] for d in data.values()]
    page.summary.append(("Interference: RED ahead of EDF (miss rate)",
                         f"{PAPER['interference_miss_lower']} % fewer misses",
                         ", ".join(f"{k} {'both 0' if v['both_zero'] else fmt_opt(v['red_miss_lower_pct'])}"
                                   for k, v in data.items()) + " %",
                         verdict(PAPER["interference_miss_lower"], min((x for x in ms if x is not None), default=None))
                         + " (worst level)"))
    page.plot(grouped_bars(page.out, "interference", "Interference: miss % (median over runs)",
                           "miss %", POLICIES, plot_rows), "interference")
    page.data["interference"] = {"measured": True, **data}


def section_fidelity(page, scenarios_dir):
    page.md += ["", "## Simulator fidelity (predicted vs measured)"]
    runs_dir = os.path.join(page.out, "runs")
    names = sorted(n for n in os.listdir(runs_dir) if run_dirs(os.path.join(runs_dir, n))) \
        if os.path.isdir(runs_dir) else []
    if not names:
        page.missing("fidelity", "no runs")
        return
    here = os.path.dirname(os.path.abspath(__file__))
    scen = [os.path.join(scenarios_dir, n + ".yaml") for n in names]
    text = subprocess.run([sys.executable, os.path.join(here, "fidelity_table.py"), runs_dir] + scen,
                          check=True, capture_output=True, text=True).stdout
    fid = os.path.join(runs_dir, "fidelity.json")
    rows = json.load(open(fid)) if os.path.exists(fid) else []
    loo = os.path.join(runs_dir, "fidelity-loo.json")
    loo_rows = json.load(open(loo)) if os.path.exists(loo) else []
    page.md += ["", "bench/fidelity_table.py over the same runs: the simulator fed the calibrated "
                "profile (ahead), a calibration on the other runs (leave one out) and, where the "
                "runs recorded it, each run's own unit costs against the real runs; target: miss "
                "rate within 5 points, mean latency within 10 % of the median real run. Its "
                "real-run tables repeat the sections above."]
    page.md += ["", text.rstrip()]
    within = sum(r["within_target"] for r in rows)
    page.summary.append(("Simulator predicts the real run (ahead)",
                         "— (not in the paper; issue 11's target)",
                         f"{within} of {len(rows)} pairs within target" if rows else "no predictions",
                         "see section"))
    own = os.path.join(runs_dir, "fidelity-own.json")
    own_rows = json.load(open(own)) if os.path.exists(own) else []
    own_within = sum(r["within_target"] for r in own_rows)
    if own_rows:
        page.summary.append(("Simulator's model, from each run's own unit costs",
                             "— (not in the paper; docs/FIDELITY.md)",
                             f"{own_within} of {len(own_rows)} policy-runs within target",
                             "see section"))
    page.data["fidelity"] = {"measured": bool(rows or loo_rows), "ahead_within": within,
                             "ahead_pairs": len(rows), "loo_rows": len(loo_rows),
                             "own_costs_within": own_within, "own_costs_runs": len(own_rows)}


def machine():
    cpu = "?"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{platform.node()}: {os.cpu_count()} CPUs ({cpu}), {platform.system()} {platform.release()}"


def build_page(out, mode, command, sources, scenarios_dir):
    page = Page(out, mode)
    section_fig6(page, "fig6_tight", "minibench-tight", "tight")
    section_fig6(page, "fig6_loose", "minibench-loose", "loose")
    section_table4(page)
    section_table5(page)
    section_ablation(page)
    section_case1(page)
    section_case2(page)
    section_table1(page)
    section_interference(page)
    section_fidelity(page, scenarios_dir)
    head = ["# Reproducing the paper's evaluation — generated page", ""]
    if mode == "quick":
        head += ["> **SMOKE RUN (`--quick`)**: the simulator stands in for real inference (two "
                 "seeds play the runs); every section is generated to check the pipeline. These "
                 "numbers are not a reproduction of the paper.", ""]
    head += [f"Generated {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} by `{command}` "
             f"on {machine()}; mode {mode}."]
    if sources:
        head += ["", "Runs read from: " + ", ".join(f"`{s}`" for s in sources) + "."]
    head += ["", "The paper's figures are citations of the RED paper (Li et al., RTSS 2023, "
             "[arXiv:2308.15368](https://arxiv.org/abs/2308.15368); four Jetson boards, GPU); ours are computed from the runs named in each section. "
             "Absolute times are not comparable, ratios are.", "", "## Summary", ""]
    head += ["| claim | paper | ours | verdict |", "|---|---|---|---|"]
    head += [f"| {c} | {p} | {o} | {v} |" for c, p, o, v in page.summary]
    text = "\n".join(head + page.md) + "\n"
    with open(os.path.join(out, "reproduction.md"), "w") as f:
        f.write(text)
    doc = {"schema": 1, "mode": mode, "command": command, "sources": sources,
           "summary": [{"claim": c, "paper": p, "ours": o, "verdict": v} for c, p, o, v in page.summary],
           "sections": page.data, "plots": page.plots}
    with open(os.path.join(out, "reproduction.json"), "w") as f:
        json.dump(doc, f, indent=1, allow_nan=False)
    return doc


# ---------------------------------------------------------------- check

HEADERS = {"fig6_tight": "## Fig. 6, tight", "fig6_loose": "## Fig. 6, loose",
           "table4": "## Table 4", "table5": "## Table 5", "ablation": "## Ablation",
           "case1": "## Case study 1", "case2": "## Case study 2",
           "table1_overheads": "## Table 1 and overheads", "interference": "## Interference",
           "fidelity": "## Simulator fidelity"}


def _reject(c):
    raise ValueError(f"non-finite number {c}")


def check(out, allow_unmeasured=()):
    """Problems with OUT's page: a missing or unmeasured section (but those in
    allow_unmeasured), a number that does not parse, a plot that is not there. Empty when all
    is well."""
    problems = []
    try:
        doc = json.load(open(os.path.join(out, "reproduction.json")), parse_constant=_reject)
    except (OSError, ValueError) as e:
        return [f"reproduction.json: {e}"]
    md = open(os.path.join(out, "reproduction.md")).read()
    for key in SECTIONS:
        if key not in doc["sections"]:
            problems.append(f"section {key} missing from reproduction.json")
        elif key != "table4" and key not in allow_unmeasured and \
                not doc["sections"][key].get("measured"):
            problems.append(f"section {key} not measured")
        if HEADERS[key] not in md:
            problems.append(f"section header '{HEADERS[key]}' missing from reproduction.md")
    if doc["mode"] == "quick" and "SMOKE RUN" not in md:
        problems.append("smoke-run banner missing")
    for line in md.splitlines():
        if line.startswith("|") and re.search(r"\b(nan|NaN|None|inf)\b", line):
            problems.append(f"a number that does not parse in table row: {line[:80]}")
    for row in (l for l in md.splitlines() if l.startswith("| ") and "[" in l):
        for m in re.finditer(r"(-?[\d.]+) \[(-?[\d.]+)–(-?[\d.]+)\]", row):
            lo, mid, hi = float(m.group(2)), float(m.group(1)), float(m.group(3))
            if not lo <= mid <= hi:
                problems.append(f"median outside its range: {m.group(0)}")
    for p in doc["plots"]:
        f = os.path.join(out, p)
        if not os.path.exists(f) or "<svg" not in open(f).read(4096):
            problems.append(f"plot {p} missing or not an svg")
    if not doc["summary"]:
        problems.append("empty summary")
    return problems


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("page")
    p.add_argument("out")
    p.add_argument("--mode", choices=["real", "reuse", "quick"], required=True)
    p.add_argument("--command", default="bench/reproduce.sh")
    p.add_argument("--source", action="append", default=[])
    p.add_argument("--scenarios", default="scenarios")
    c = sub.add_parser("check")
    c.add_argument("out")
    c.add_argument("--allow-unmeasured", default="",
                   help="comma-separated sections that may be unmeasured")
    a = ap.parse_args()
    if a.cmd == "page":
        if not os.path.isdir(a.out):
            print(f"reproduce.py: {a.out}: no such directory", file=sys.stderr)
            return 2
        doc = build_page(a.out, a.mode, a.command, a.source, a.scenarios)
        print(f"wrote {a.out}/reproduction.md, reproduction.json, {len(doc['plots'])} plots")
        return 0
    problems = check(a.out, [x for x in a.allow_unmeasured.split(",") if x])
    for p in problems:
        print(f"reproduce.py check: {a.out}: {p}", file=sys.stderr)
    if not problems:
        print(f"reproduce.py check: {a.out}: every section present, numbers parse")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())

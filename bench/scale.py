#!/usr/bin/env python3
"""How RED's cost grows with the size of the workload (docs/journal/decision-and-simulator.md,
"Issue 39 item 7").

Times, RUNS times each, with the load average before and after:
  * `red --version` and `red validate` of a small scenario (the process start);
  * `red validate` of one operation that is a chain of N plain nodes (N - 1 edges);
  * `red validate` of N operations, each a 4-node diamond of plain nodes;
  * `red simulate --policy red` of N copies of that diamond (own rate 1 Hz, 20 s), the
    simulator's own time as `red simulate` reports it ("simulated ... in X s"): copies
    whose releases are spread over the period ("spread") and copies that all release at
    the same instant ("together").

Usage: bench/scale.py [--red build/tools/red/red] [--runs 3] [--quick] [--out out/scale]
Prints one line per measurement: what, size, min / median / max seconds (wall, or the
simulator's own time), then the process's CPU time (user + system; on a busy machine the
wall time includes waiting for a core). Not part of CI.
"""

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import time


def chain(n):
    lines = ["name: chain-%d" % n, "duration_s: 10", "device: {lanes: 1}", "operations:",
             "  - name: chain", "    rate_hz: 1", "    deadline_ms: 1000", "    nodes:"]
    lines += ["      n%d: {cost_ms: 0.01}" % i for i in range(n)]
    lines.append("    edges:")
    lines += ["      - [n%d, n%d]" % (i, i + 1) for i in range(n - 1)]
    return "\n".join(lines) + "\n"


def diamonds(n, together):
    """n copies of a 4-node diamond at 1 Hz; phases spread over the second unless together."""
    lines = ["name: copies-%d" % n, "duration_s: 20", "warmup_s: 1", "seed: 1",
             "device: {lanes: 2}", "operations:"]
    for i in range(n):
        lines += ["  - name: op%d" % i, "    rate_hz: 1"]
        if not together:
            lines.append("    phase_ms: %.3f" % (1000.0 * i / n))
        lines += ["    deadline_ms: 1000", "    nodes:"]
        lines += ["      %s: {cost_ms: 0.01}" % k for k in "abcd"]
        lines.append("    edges: [[a, b], [a, c], [b, d], [c, d]]")
    return "\n".join(lines) + "\n"


def load():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def cpu_children():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def measure(cmd, runs, sim_time=False):
    """Seconds per run: wall time, or the simulator's own time (sim_time); and CPU time."""
    out, cpu = [], []
    for _ in range(runs):
        c0 = cpu_children()
        t0 = time.perf_counter()
        p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        wall = time.perf_counter() - t0
        cpu.append(cpu_children() - c0)
        if p.returncode != 0:
            sys.exit("scale: %s exited %d: %s" % (" ".join(cmd), p.returncode, p.stderr[-500:]))
        if sim_time:
            m = re.search(r"simulated \S+ on \S+ in ([0-9.]+) s", p.stderr)
            if not m:
                sys.exit("scale: no 'simulated ... in X s' line from %s" % " ".join(cmd))
            out.append(float(m.group(1)))
        else:
            out.append(wall)
    return out, cpu


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--red", default="build/tools/red/red")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default="out/scale")
    ap.add_argument("--quick", action="store_true", help="smaller sizes (a check that it runs)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    here = os.path.dirname(os.path.abspath(__file__))
    small = os.path.join(here, "..", "scenarios", "minibench-tight.yaml")
    chains = [500, 2000] if a.quick else [5000, 20000, 50000]
    ops = [100, 1000] if a.quick else [1000, 5000, 10000]
    copies = [10, 100] if a.quick else [10, 100, 1000]
    print("scale: %s, %d cores, load %s, %d run(s) each; seconds min / median / max"
          % (a.red, os.cpu_count(), load(), a.runs))

    def report(what, size, m):
        xs, cpu = m
        print("%-34s %7s  %8.3f %8.3f %8.3f   cpu %8.3f %8.3f %8.3f"
              % (what, size, min(xs), statistics.median(xs), max(xs), min(cpu),
                 statistics.median(cpu), max(cpu)), flush=True)

    report("red --version", "-", measure([a.red, "--version"], a.runs))
    report("red validate minibench-tight", "-", measure([a.red, "validate", small], a.runs))
    for n in chains:
        path = os.path.join(a.out, "chain-%d.yaml" % n)
        with open(path, "w") as f:
            f.write(chain(n))
        report("red validate chain (nodes)", n, measure([a.red, "validate", path], a.runs))
    for n in ops:
        path = os.path.join(a.out, "ops-%d.yaml" % n)
        with open(path, "w") as f:
            f.write(diamonds(n, False))
        report("red validate diamonds (operations)", n, measure([a.red, "validate", path], a.runs))
    for together in (False, True):
        for n in copies:
            path = os.path.join(a.out, "copies-%s-%d.yaml" % ("together" if together else "spread", n))
            with open(path, "w") as f:
                f.write(diamonds(n, together))
            report("simulate copies, %s" % ("together" if together else "spread"), n,
                   measure([a.red, "simulate", path, "--policy", "red"], a.runs, sim_time=True))
    print("scale: load after %s" % load())


if __name__ == "__main__":
    main()

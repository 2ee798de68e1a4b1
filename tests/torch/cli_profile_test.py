#!/usr/bin/python3
"""End-to-end test of `red profile`: exit codes, located messages and the JSON it writes.

Usage: cli_profile_test.py RED_BINARY SCRATCH_DIR
Uses only the standard library. A small input keeps the run to a few seconds; nothing
here depends on how long anything took.
"""

import json
import os
import subprocess
import sys


def run(red, *args):
    p = subprocess.run([red, "profile", *args], capture_output=True, text=True, timeout=300)
    return p.returncode, p.stdout, p.stderr


def check(cond, what, out="", err=""):
    if not cond:
        print(f"FAIL: {what}\n--- stdout\n{out}\n--- stderr\n{err}", file=sys.stderr)
        sys.exit(1)
    print(f"ok: {what}")


def main():
    red, scratch = sys.argv[1], sys.argv[2]
    os.makedirs(scratch, exist_ok=True)
    out_json = os.path.join(scratch, "profile.json")
    if os.path.exists(out_json):
        os.remove(out_json)

    rc, out, err = run(red, "--input", "3,32,64", "--heads", "lane,steer", "--runs", "2",
                       "--warmup", "0", "--max-batch", "2", "--threads", "2", "--out", out_json)
    check(rc == 0, "profile runs (exit 0)", out, err)
    check("encoder" in out and "separate/steer" in out and "separate / shared" in out,
          "prints the unit table and the shared/separate comparison", out, err)
    check("red profile:" in err, "progress goes to stderr", out, err)
    with open(out_json) as f:
        doc = json.load(f)
    check(doc["schema"] == 1 and doc["source"] == "measured", "JSON schema and source")
    check(doc["model"] == "mimonet [3,32,64]" and doc["device"] == "cpu (2 threads)",
          "JSON model and device labels", json.dumps(doc)[:400])
    units = doc["units"]
    check(sorted(units) == sorted(["encoder", "head/lane", "head/steer", "coarse/lane",
                                   "coarse/steer", "separate/lane", "separate/steer"]),
          "JSON has every unit", sorted(units))
    check(len(units["encoder"]) == 2 and len(units["coarse/lane"]) == 1,
          "encoder and heads at batch 1..2, coarse at batch 1")
    check(all(e["samples"] == 2 for u in units.values() for e in u), "samples = runs")
    m = doc["measurement"]
    check(m["timing"] == "host wall clock" and m["warmup_min"] == 0 and m["device_warmup_s"] == 0,
          "how the units were timed and warmed is recorded", json.dumps(m))
    mem = doc["memory"]
    check(mem["separate"]["parameter_bytes"] > mem["shared"]["parameter_bytes"] > 0,
          "memory figures for shared and separate")
    # Profile quality (docs/CLI.md, "Profile quality"): the machine while measuring, the
    # findings and a verdict; each finding a `red: warning:` line at the end of stderr.
    q = doc["quality"]
    check(q["verdict"] in ("good", "suspect") and
          (q["verdict"] == "suspect") == (len(q["findings"]) > 0),
          "quality: a verdict that agrees with the findings", json.dumps(q)[:400])
    qm = q["machine"]
    check(qm["threads"] == 2 and qm["online_cpus"] >= 1 and qm["wall_s"] > 0 and
          "other_busy_cpus" in qm and "load1_before" in qm and "load1_after" in qm,
          "quality: the machine state is recorded", json.dumps(qm))
    check(all(f["kind"] in ("spread", "non_monotone", "oversubscribed") and f["message"] and
              f["advice"] for f in q["findings"]), "quality: each finding says what and what to do",
          json.dumps(q["findings"])[:400])
    check(err.count("red: warning: ") == (len(q["findings"]) + 1 if q["findings"] else 0),
          "one warning per finding on stderr (and a heading)", out, err)
    # red validate and red analyze warn about a suspect profile, changing nothing else.
    suspect = dict(doc)
    suspect["quality"] = {"verdict": "suspect", "findings": [
        {"unit": "encoder", "batch": 2, "kind": "non_monotone", "figures": {},
         "message": "encoder: batch 2 costs less in all", "advice": "measure again"}]}
    suspect_json = os.path.join(scratch, "suspect.json")
    with open(suspect_json, "w") as f:
        json.dump(suspect, f)
    good = dict(doc)
    good["quality"] = {"verdict": "good", "findings": []}
    good_json = os.path.join(scratch, "good.json")
    with open(good_json, "w") as f:
        json.dump(good, f)
    small = os.path.join(scratch, "small.yaml")
    with open(small, "w") as f:
        f.write("name: small\nduration_s: 1\nwarmup_s: 0.1\nseed: 3\ndevice: {lanes: 1}\n"
                "model: {builtin: mimonet, heads: [lane, steer], input: [3, 32, 64]}\n"
                "sensors:\n  camera: {rate_hz: 20}\noperations:\n  - name: drive\n"
                "    trigger: camera\n    deadline_ms: 1000\n    nodes:\n"
                "      L: {head: lane, sensor: camera}\n      C: {head: steer, sensor: camera}\n"
                "    edges: [[L, C]]\n")
    for command in ("validate", "analyze"):
        runs = {}
        for label, path in (("suspect", suspect_json), ("good", good_json)):
            r = subprocess.run([red, command, small, "--profile", path], capture_output=True,
                               text=True, timeout=120)
            runs[label] = r
        s, g = runs["suspect"], runs["good"]
        # The same output but for the profile's own path (validate's "checked:" names it).
        check(s.returncode == g.returncode and
              s.stdout.replace(suspect_json, "P") == g.stdout.replace(good_json, "P") and
              "red: warning: profile " + suspect_json in s.stderr and
              "batch 2 costs less in all (measure again)" in s.stderr and
              "red: warning" not in g.stderr,
              f"red {command} warns about a suspect profile, output and exit code unchanged",
              s.stdout, s.stderr + "\n--- good\n" + g.stderr)

    # Warm-up until stable: at least --warmup untimed runs per unit and batch size, recorded.
    warm_json = os.path.join(scratch, "warm.json")
    rc, out, err = run(red, "--input", "3,32,64", "--heads", "lane", "--no-separate", "--runs",
                       "6", "--warmup", "2", "--max-batch", "2", "--quiet", "--out", warm_json)
    check(rc == 0, "profile with a warm-up (exit 0)", out, err)
    with open(warm_json) as f:
        warm = json.load(f)
    check(all(e["warmup_runs"] >= 2 and e["samples"] == 6 for u in warm["units"].values()
              for e in u), "each unit and batch size warmed at least --warmup runs",
          json.dumps(warm["units"])[:400])
    wm = warm["measurement"]
    check(wm["warmup_min"] == 2 and wm["window"] == 2 and wm["warmup_max"] >= 2 and
          0 <= wm["unstable"] <= 5, "the warm-up rule is recorded", json.dumps(wm))
    # No --threads: the CPUs not busy with other processes, at least 1 and at most every one.
    threads = warm["quality"]["machine"]["threads"]
    check(1 <= threads <= (os.cpu_count() or 1) and
          warm["device"] == f"cpu ({threads} thread{'s' if threads > 1 else ''})",
          "the default thread count does not exceed the CPUs", json.dumps(warm["quality"]))

    rc, out, err = run(red, "--input", "3,32,64", "--no-separate", "--runs", "1", "--warmup",
                       "0", "--max-batch", "1", "--quiet")
    # --quiet: no progress line (a suspect profile's `red: warning:` lines still come).
    check(rc == 0 and "separate/" not in out and "red profile:" not in err,
          "--no-separate and --quiet", out, err)

    bad_manifest = os.path.join(scratch, "bad.yaml")
    with open(bad_manifest, "w") as f:
        f.write("encoder: enc.pt\nheads: {a: a.pt}\ninput: [3, 8, 8]\nextra: 1\n")
    cases = [
        (["--input", "3,x,8"], "--input"),
        (["--input", "3,64"], "--input"),
        (["--heads", "lane,radar"], "unknown head 'radar'"),
        (["--runs", "0"], "--runs"),
        (["--device", "tpu"], "unknown device 'tpu'"),
        (["--model", bad_manifest], bad_manifest + ":1: encoder file 'enc.pt' not found"),
        (["--model", os.path.join(scratch, "missing.yaml")], "missing.yaml: cannot open"),
        (["--no-such-flag"], ""),
    ]
    for args, message in cases:
        rc, out, err = run(red, *args)
        check(rc == 2 and message in err, f"bad input {args} -> exit 2 naming the problem", out,
              err)

    # An --out that cannot be written is found before measuring (it took a whole profile to
    # say so): exit 1, the path and the system's reason, and no progress line.
    unwritable = os.path.join(scratch, "no-such-dir", "p.json")
    rc, out, err = run(red, "--out", unwritable)
    check(rc == 1 and unwritable in err and "No such file or directory" in err and
          "before measuring" in err and "red profile:" not in err,
          "an unwritable --out is an error before measuring", out, err)

    # Calibration (docs/FIDELITY.md): real runs of a small scenario on the measured profile.
    # A deadline far above any unit's time: on a loaded machine (ctest -j2 beside LibTorch
    # tests, 2 cores) a 50 ms deadline dropped every job before its heads ran, and the
    # calibration then had no head to measure.
    scenario = os.path.join(scratch, "calib.yaml")
    with open(scenario, "w") as f:
        f.write("name: calib\nduration_s: 2\nwarmup_s: 0.2\nseed: 3\ndevice: {lanes: 1}\n"
                "model: {builtin: mimonet, heads: [lane, steer], input: [3, 32, 64]}\n"
                "sensors:\n  camera: {rate_hz: 20}\noperations:\n  - name: drive\n"
                "    trigger: camera\n    deadline_ms: 1000\n    nodes:\n"
                "      L: {head: lane, sensor: camera}\n      C: {head: steer, sensor: camera}\n"
                "    edges: [[L, C]]\n")
    calibrated = os.path.join(scratch, "calibrated.json")
    rc, out, err = run(red, "--from", out_json, "--calibrate", scenario, "--calibrate-s", "2",
                       "--calibrate-policies", "edf,red,mono", "--quiet", "--out", calibrated)
    check(rc == 0, "--from F --calibrate S runs (exit 0)", out, err)
    check("in-run ms" in out and "time factor" in out and "lane factor" in out,
          "prints how the run departs from the isolated profile", out, err)
    with open(calibrated) as f:
        doc = json.load(f)
    cal = doc["calibration"]
    # 2 s per policy: two turns of 1 s each, the policies alternating, the first of each
    # round moving one on.
    check(doc["source"] == "calibrated" and
          cal["policies"] == ["edf", "red", "mono", "red", "mono", "edf"],
          "calibrated source and the policies' turns, in the order played", json.dumps(cal)[:300])
    check({"encoder", "head/lane", "head/steer", "coarse/lane", "mono/drive"} <= set(cal["residual"]),
          "residual tables of the fine, coarse and mono units", sorted(cal["residual"]))
    check(all(len(t) == 201 for u in cal["residual"].values() for t in u if t),
          "201 quantiles per table")
    check(len(cal["factors"]) > 0 and all(0.05 <= x <= 20 for x in cal["factors"]),
          "time factors measured")
    check(doc["units"]["encoder"][0]["samples"] > 2, "in-run statistics replace the isolated ones")
    # The simulator reads the calibrated profile.
    sim = subprocess.run([red, "simulate", scenario, "--profile", calibrated, "--policy", "red"],
                         capture_output=True, text=True, timeout=120)
    check(sim.returncode == 0 and "calibrated" in sim.stdout, "simulate with a calibrated profile",
          sim.stdout, sim.stderr)
    bad_run = os.path.join(scratch, "badrun")
    os.makedirs(bad_run, exist_ok=True)
    with open(os.path.join(bad_run, "units.csv"), "w") as f:
        f.write("policy,lane\nred,0\n")
    bad = [
        (["--from", out_json, "--calibrate", scenario, "--calibrate-from", bad_run],
         "units.csv:1: not a units.csv"),
        (["--from", out_json, "--calibrate", scenario, "--calibrate-from",
          os.path.join(scratch, "norun")], "norun/units.csv"),
        (["--from", out_json], "--from needs --calibrate"),
        (["--from", out_json, "--calibrate", os.path.join(scratch, "none.yaml")], "none.yaml"),
        (["--from", out_json, "--calibrate", scenario, "--calibrate-policies", "edf,nope"],
         "unknown policy 'nope'"),
        (["--from", out_json, "--calibrate", scenario, "--calibrate-s", "0"], "--calibrate-s"),
        (["--from", out_json, "--calibrate", scenario, "--calibrate-rounds", "0"],
         "--calibrate-rounds must be at least 1"),
        (["--from", out_json, "--calibrate", scenario, "--calibrate-s", "2",
          "--calibrate-rounds", "3"], "at least 1 s of the 2 s of --calibrate-s (got 3)"),
        (["--from", os.path.join(scratch, "missing.json"), "--calibrate", scenario], "missing.json"),
    ]
    # The calibration runs where it is told to, or where the profile was measured: a device
    # that is not there is an error naming it, never a calibration on the CPU (it once ran
    # every "CUDA" calibration on the CPU and exited 0).
    with open(out_json) as f:
        gpu_doc = json.load(f)
    gpu_doc["device"] = "cuda:0"
    gpu_profile = os.path.join(scratch, "gpu-profile.json")
    with open(gpu_profile, "w") as f:
        json.dump(gpu_doc, f)
    has_cuda = subprocess.run([sys.executable, "-c",
                               "import torch, sys; sys.exit(0 if torch.cuda.is_available() else 1)"],
                              capture_output=True).returncode == 0
    # A CPU profile calibrated on a GPU mixes devices; without a GPU, the GPU is not there.
    bad.append((["--from", out_json, "--calibrate", scenario, "--device", "cuda"], "cuda"))
    if not has_cuda:
        bad.append((["--from", gpu_profile, "--calibrate", scenario], "cuda"))
        bad.append((["--device", "cuda", "--input", "3,32,64"], "'cuda'"))
    else:
        bad.append((["--from", gpu_profile, "--calibrate", scenario, "--device", "cpu"],
                    "measured on cuda:0"))
    for args, message in bad:
        rc, out, err = run(red, *args)
        check(rc == 2 and message in err, f"bad input {args} -> exit 2 naming the problem", out,
              err)
    return 0


if __name__ == "__main__":
    sys.exit(main())

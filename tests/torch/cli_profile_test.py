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
    mem = doc["memory"]
    check(mem["separate"]["parameter_bytes"] > mem["shared"]["parameter_bytes"] > 0,
          "memory figures for shared and separate")

    rc, out, err = run(red, "--input", "3,32,64", "--no-separate", "--runs", "1", "--warmup",
                       "0", "--max-batch", "1", "--quiet")
    check(rc == 0 and "separate/" not in out and err == "", "--no-separate and --quiet", out, err)

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
    return 0


if __name__ == "__main__":
    sys.exit(main())

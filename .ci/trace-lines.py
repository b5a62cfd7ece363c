#!/usr/bin/env python3
"""Prints the records of an mbs trace file (docs/determinism.md, "Traces")
as the lines the firmware prints (firmware/golden: `golden::Record`):
`trace STEP PHASE DIGEST` and the field groups' digests in the order
positions, velocities, spins, springs, flow.

Usage: python3 .ci/trace-lines.py TRACE.json
"""
import json
import sys

GROUPS = ["positions", "velocities", "spins", "springs", "flow"]

body = json.load(open(sys.argv[1]))["body"]
for r in body["records"]:
    print(" ".join(["trace", str(r["step"]), r["phase"], r["digest"]] + [r["groups"][g] for g in GROUPS]))

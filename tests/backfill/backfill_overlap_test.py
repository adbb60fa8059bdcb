#!/usr/bin/env python3
"""Two `lane backfill` processes on the same shard at once (issue 47: a
replacement pod started while the old one still runs), and outputs that
do not check:

  1. 20 rounds of the same shard run twice at once on one output folder:
     both exit 0; every published output parses, ends with a trailer that
     checks (frame count, SHA-256), and equals a single run's without
     timings; each recording is computed and published by exactly one of
     the two (its "done" line), the other skips it; no partial or lock file
     is left;
  2. a torn output (cut in half), one without a trailer (as written before
     trailers) and stale partial files of a dead process: --verify says
     which (exit 1); a run redoes exactly those two, removes the stale
     partials, and --verify then passes;
  3. a claim held by another process: the recording is left to it, waited
     for at the end, and done here when the holder lets go without
     publishing.

usage: backfill_overlap_test.py LANE SOURCE_DIR
"""
import fcntl
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
import time

LANE, SRC = sys.argv[1], sys.argv[2]
CONFIG = os.path.join(SRC, "configs", "synthetic.json")
NAMES = ["r1", "r2", "r3", "r4"]
ROUNDS = 20
STATUS = re.compile(
    r"^lane backfill: shard 0/1: (\S+): (done|redone|skipped|failed)\b.*\((\d+) frames", re.M)


def fail(message):
    print("FAIL: " + message, flush=True)
    sys.exit(1)


def read_output(path):
    """The frame records of a published output without timings, after
    checking that every line parses and the trailer checks."""
    with open(path, "rb") as f:
        data = f.read()
    if not data.endswith(b"\n"):
        fail("%s: does not end with a newline" % path)
    lines = data.splitlines(keepends=True)
    records = [json.loads(line) for line in lines]  # every line parses
    trailer = records[-1].get("trailer")
    if not isinstance(trailer, dict):
        fail("%s: the last line is not a trailer" % path)
    if trailer["frames"] != len(lines) - 1:
        fail("%s: the trailer counts %s frames, the file has %d" % (path, trailer["frames"],
                                                                    len(lines) - 1))
    if trailer["sha256"] != hashlib.sha256(b"".join(lines[:-1])).hexdigest():
        fail("%s: the trailer's sha256 does not match" % path)
    for r in records[:-1]:
        r.pop("timing_ms", None)
    return records[:-1]


def backfill(out, *extra, **kwargs):
    return subprocess.run([LANE, "backfill", "--manifest", MANIFEST, "--output-dir", out] +
                          list(extra), capture_output=True, text=True, **kwargs)


def stray_files(out):
    return [f for f in os.listdir(out) if f.startswith(".")]


with tempfile.TemporaryDirectory() as d:
    MANIFEST = os.path.join(d, "manifest.jsonl")
    with open(MANIFEST, "w") as m:
        for k, name in enumerate(NAMES):
            subprocess.run([LANE, "render", "--config", CONFIG, "--sequence", "--count", "4",
                            "--seed", str(k + 1), "--format", "jpg", "--output",
                            os.path.join(d, name)],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            m.write(json.dumps({"recording": name, "config": CONFIG, "output": name}) + "\n")

    ref_dir = os.path.join(d, "ref")
    r = backfill(ref_dir, "-q")
    if r.returncode != 0:
        fail("single run: exit %d\n%s" % (r.returncode, r.stderr))
    ref = {n: read_output(os.path.join(ref_dir, n + ".jsonl")) for n in NAMES}

    # 1. The same shard twice at once, 20 times over.
    overlapped = 0
    start = time.monotonic()
    for k in range(ROUNDS):
        out = os.path.join(d, "round%d" % k)
        procs = [subprocess.Popen([LANE, "backfill", "--manifest", MANIFEST, "--output-dir", out],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                 for _ in range(2)]
        errs = [p.communicate(timeout=120)[1] for p in procs]
        for p, err in zip(procs, errs):
            if p.returncode != 0:
                fail("round %d: exit %d\n%s" % (k, p.returncode, err))
        for n in NAMES:
            if read_output(os.path.join(out, n + ".jsonl")) != ref[n]:
                fail("round %d: %s differs from the single run's" % (k, n))
        # Each recording computed (its frames counted) and published ("done")
        # by exactly one of the two; the other skips it without computing.
        statuses = {n: [] for n in NAMES}
        for err in errs:
            for name, status, frames in STATUS.findall(err):
                statuses[name].append((status, int(frames)))
        for n in NAMES:
            if sorted(statuses[n]) != [("done", 4), ("skipped", 0)]:
                fail("round %d: %s: %s (expected done by one process, skipped by the other)\n%s" %
                     (k, n, statuses[n], "\n".join(errs)))
        if stray_files(out):
            fail("round %d: left %s" % (k, stray_files(out)))
        overlapped += any("claimed by another process" in err for err in errs)
    print("ok: %d rounds of two processes on one shard (%d with a recording claimed by the other) "
          "in %.1f s: every output whole, equal to a single run's, published once" %
          (ROUNDS, overlapped, time.monotonic() - start), flush=True)
    if overlapped == 0:
        fail("no round overlapped: the test did not test anything")

    # 2. Torn outputs and a dead process's partial files.
    out = os.path.join(d, "round%d" % (ROUNDS - 1))
    r = backfill(out, "--verify")
    if r.returncode != 0:
        fail("--verify of a whole folder: exit %d\n%s%s" % (r.returncode, r.stdout, r.stderr))
    r1, r2 = os.path.join(out, "r1.jsonl"), os.path.join(out, "r2.jsonl")
    os.truncate(r1, os.path.getsize(r1) // 2)
    with open(r2, "rb") as f:
        lines = f.read().splitlines(keepends=True)
    with open(r2, "wb") as f:
        f.write(b"".join(lines[:-1]))  # no trailer: written before trailers
    for stale in (".r1.jsonl.partial.99999.0123456789abcdef", ".r1.jsonl.partial"):
        with open(os.path.join(out, stale), "w") as f:
            f.write('{"schema":1,"frame":"half a line')
    r = backfill(out, "--verify")
    if r.returncode != 1 or "torn %s" % r1 not in r.stdout or "torn %s" % r2 not in r.stdout:
        fail("--verify of torn outputs: exit %d\n%s%s" % (r.returncode, r.stdout, r.stderr))
    r = backfill(out, "-q")
    if r.returncode != 0:
        fail("the run after tearing: exit %d\n%s" % (r.returncode, r.stderr))
    with open(os.path.join(out, "summary-shard-0-of-1.json")) as f:
        by = {x["output"]: x for x in json.load(f)["recordings"]}
    if [by[n]["status"] for n in NAMES] != ["redone", "redone", "skipped", "skipped"]:
        fail("after tearing: %s" % by)
    if by["r1"].get("removed_partials") != 2:
        fail("the dead process's partial files: %s" % by["r1"])
    for n in NAMES:
        if read_output(os.path.join(out, n + ".jsonl")) != ref[n]:
            fail("after tearing: %s differs from the single run's" % n)
    r = backfill(out, "--verify")
    if r.returncode != 0 or stray_files(out):
        fail("--verify after the redo: exit %d, left %s\n%s" % (r.returncode, stray_files(out),
                                                                 r.stdout))
    print("ok: a torn output and one without a trailer: --verify found them, a run redid them "
          "(%s; %s) and removed 2 stale partial files" % (by["r1"]["redone_because"],
                                                          by["r2"]["redone_because"]), flush=True)

    # 3. A claim held elsewhere: left, waited for, done when released.
    os.remove(os.path.join(out, "r3.jsonl"))
    lock = open(os.path.join(out, ".r3.jsonl.lock"), "w")
    fcntl.flock(lock, fcntl.LOCK_EX)
    proc = subprocess.Popen([LANE, "backfill", "--manifest", MANIFEST, "--output-dir", out],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    waited = ""
    deadline = time.monotonic() + 60
    while "waiting for it" not in waited and time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line:
            break
        waited += line
    if "r3: claimed by another process; waiting for it" not in waited:
        proc.kill()
        fail("a held claim: no wait\n" + waited)
    time.sleep(0.3)
    if proc.poll() is not None:
        fail("a held claim: lane did not wait for it")
    lock.close()  # the holder goes without publishing
    rest = proc.communicate(timeout=60)[1]
    if proc.returncode != 0:
        fail("a held claim: exit %d\n%s%s" % (proc.returncode, waited, rest))
    with open(os.path.join(out, "summary-shard-0-of-1.json")) as f:
        by = {x["output"]: x for x in json.load(f)["recordings"]}
    if by["r3"]["status"] != "done" or not by["r3"].get("claimed_elsewhere"):
        fail("a held claim: %s" % by["r3"])
    if read_output(os.path.join(out, "r3.jsonl")) != ref["r3"] or stray_files(out):
        fail("a held claim: r3 differs, or left %s" % stray_files(out))
    print("ok: a recording claimed elsewhere was waited for and done when the claim was let go")

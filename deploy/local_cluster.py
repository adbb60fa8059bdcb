#!/usr/bin/python3
"""Scale-out proof on one machine (deploy/local-cluster.sh is the entry point).

Starts REPLICAS lane-server processes on 127.0.0.1, each with its own gRPC and
metrics port, and puts load on all of them through gRPC round_robin:

  * `lane-client bench` (open loop) over one round_robin channel to every
    replica, for a fixed time;
  * STREAMS concurrent loops of `lane-client stream` runs over the same
    replicas (round_robin), each run a list of rendered frames. A stream
    keeps every unanswered frame and resends it after a reconnection, so its
    JSON Lines must hold every frame exactly once, in order.

During the run the busiest replica (most frames over the last 0.3 s, so the
one most likely to hold streams) is stopped with SIGTERM: it drains and exits.
Later the busiest of the others is killed with SIGKILL and restarted on the
same ports. Every
replica's /metrics is scraped with curl every 0.5 s (the last scrape of each
process counts). The report gives lost and duplicated frames, what the
reconnections resent, and the frames each replica answered. Exit status: 0,
1 when a frame was lost, duplicated or reordered, a stream failed, the load
was not spread, or a replica misbehaved, 2 for a bad command line or a
missing binary.
"""

import argparse
import collections
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def log(message):
    print("local-cluster: " + message, file=sys.stderr, flush=True)


def parse_args():
    p = argparse.ArgumentParser(
        description="3 lane-server replicas on loopback, round_robin load, a SIGTERM and a "
        "SIGKILL+restart mid-run; checks every stream frame is answered exactly once.")
    p.add_argument("--short", action="store_true",
                   help="the CI version: a 12 s measured bench (about 25 s in all)")
    p.add_argument("--duration", type=float, help="measured bench time, s (default 40, short 12)")
    p.add_argument("--replicas", type=int, default=3, help="server replicas (default 3, at least 3)")
    p.add_argument("--streams", type=int, default=3,
                   help="concurrent exactly-once stream loops (default 3)")
    p.add_argument("--cameras", type=int, default=6, help="bench cameras (default 6)")
    p.add_argument("--fps", type=float, default=10.0,
                   help="bench frames/s per camera, open loop (default 10)")
    p.add_argument("--frames-per-run", type=int, default=120,
                   help="frames of one stream run (default 120)")
    p.add_argument("--out", default=os.environ.get("OUT", "out/local-cluster"),
                   help="work and log folder (default out/local-cluster, or $OUT)")
    args = p.parse_args()
    if args.duration is None:
        args.duration = 12.0 if args.short else 40.0
    if args.replicas < 3:
        p.error("--replicas must be at least 3 (one is stopped, one killed)")
    return args


def binaries():
    build = os.environ.get("BUILD_DIR", "build")
    if not os.path.isabs(build) and not os.path.isdir(build):
        build = os.path.join(REPO, build)
    paths = {
        "server": os.environ.get("LANE_SERVER", os.path.join(build, "server", "lane-server")),
        "client": os.environ.get("LANE_CLIENT", os.path.join(build, "client", "lane-client")),
        "lane": os.environ.get("LANE_CLI", os.path.join(build, "cli", "lane")),
    }
    missing = [p for p in paths.values() if not os.access(p, os.X_OK)]
    if missing:
        log("missing " + ", ".join(missing) + " (set BUILD_DIR, or build lane-server, "
            "lane-client and lane)")
        sys.exit(2)
    return paths


def free_ports(n):
    """n distinct free TCP ports on 127.0.0.1 (BASE_PORT=P uses P, P+1, ...)."""
    base = os.environ.get("BASE_PORT")
    if base:
        return [int(base) + i for i in range(n)]
    sockets, ports = [], []
    for _ in range(n):
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        sockets.append(s)
        ports.append(s.getsockname()[1])
    for s in sockets:
        s.close()
    return ports


METRIC_LINE = re.compile(r'^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{[^}]*\})?\s+(\S+)')


def parse_metrics(text):
    """{(name, labels-string): value} of a Prometheus text exposition."""
    out = {}
    for line in text.splitlines():
        if line.startswith("#"):
            continue
        m = METRIC_LINE.match(line)
        if m:
            try:
                out[(m.group(1), m.group(2) or "")] = float(m.group(3))
            except ValueError:
                pass
    return out


def summarize(metrics):
    """The counters the report uses, from one scrape."""
    s = collections.Counter()
    for (name, labels), value in metrics.items():
        if name == "lanesvc_frames_total":
            result = re.search(r'result="([^"]*)"', labels)
            s["frames_" + (result.group(1) if result else "?")] += value
        elif name == "lanesvc_frames_received_total":
            s["received"] += value
        elif name == "grpc_server_handled_total":
            method = re.search(r'grpc_method="([^"]*)"', labels)
            code = re.search(r'grpc_code="([^"]*)"', labels)
            if method and method.group(1) == "StreamFrames":
                s["streams_" + (code.group(1) if code else "?")] += value
    return s


class Replica:
    def __init__(self, index, server, grpc_port, metrics_port, out, deadline):
        self.index = index
        self.server = server
        self.grpc_port = grpc_port
        self.metrics_port = metrics_port
        self.out = out
        self.deadline = deadline
        self.incarnations = []  # one dict per process: pid, last scrape summary, ...
        self.proc = None
        self.lock = threading.Lock()

    @property
    def target(self):
        return "127.0.0.1:%d" % self.grpc_port

    def start(self):
        n = len(self.incarnations)
        logf = open(os.path.join(self.out, "replica-%d.%d.log" % (self.index, n)), "w")
        cmd = [self.server,
               "--address=127.0.0.1:%d" % self.grpc_port,
               "--metrics_address=127.0.0.1:%d" % self.metrics_port,
               "--default_config=" + os.path.join(REPO, "configs", "synthetic.json"),
               "--workers=1",
               "--shutdown_deadline=%ds" % self.deadline]
        self.proc = subprocess.Popen(cmd, stdout=logf, stderr=subprocess.STDOUT)
        with self.lock:
            self.incarnations.append({"pid": self.proc.pid, "last": collections.Counter(),
                                      "scrapes": 0, "started": time.monotonic(),
                                      "exit": None})

    def scrape(self):
        """Scrapes /metrics once; keeps the result if the process is the current one."""
        proc = self.proc
        if proc is None or proc.poll() is not None:
            return
        r = subprocess.run(["curl", "-s", "--max-time", "2",
                            "http://127.0.0.1:%d/metrics" % self.metrics_port],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        if r.returncode != 0 or "lanesvc_" not in r.stdout:
            return
        with self.lock:
            inc = self.incarnations[-1]
            if inc["pid"] == proc.pid:
                inc["last"] = summarize(parse_metrics(r.stdout))
                inc["scrapes"] += 1

    def totals(self):
        with self.lock:
            total = collections.Counter()
            for inc in self.incarnations:
                total.update(inc["last"])
            return total


def wait_healthy(client, targets, timeout):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        r = subprocess.run([client, "health", "--target", ",".join(targets), "--timeout", "1s"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if r.returncode == 0:
            return True
        time.sleep(0.1)
    return False


class StreamLoop(threading.Thread):
    """Runs `lane-client stream` over the list, again and again, until stopped."""

    def __init__(self, index, client, targets, list_file, names, out):
        super().__init__(daemon=True)
        self.index = index
        self.client = client
        self.targets = targets
        self.list_file = list_file
        self.names = names
        self.out = out
        self.stop = threading.Event()
        self.runs = []

    def run(self):
        n = 0
        while not self.stop.is_set():
            output = os.path.join(self.out, "stream-%d.%03d.jsonl" % (self.index, n))
            errlog = os.path.join(self.out, "stream-%d.%03d.log" % (self.index, n))
            # Each run is a new process and channel. Its first call goes to the
            # replica that accepts first, so rotate the address list, as a
            # DNS server shuffling its A records would (CoreDNS' loadbalance).
            k = (self.index + n) % len(self.targets)
            target = "ipv4:" + ",".join(self.targets[k:] + self.targets[:k])
            cmd = [self.client, "stream", "--target", target,
                   "--camera", "cluster-stream-%d" % self.index,
                   "--config", os.path.join(REPO, "configs", "synthetic.json"),
                   "--window", "2", "--retry-timeout", "30s", "--stall-timeout", "10s",
                   "--output", output, self.list_file]
            started = time.monotonic()
            with open(errlog, "w") as err:
                try:
                    rc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=err,
                                        timeout=120).returncode
                except subprocess.TimeoutExpired:
                    rc = "timeout"
            self.runs.append(check_stream_run(output, errlog, self.names, rc,
                                              started, time.monotonic()))
            n += 1


SUMMARY = re.compile(r"(\d+) frames: (\d+) ok, (\d+) failed; (\d+) connection\(s\), "
                     r"(\d+) frame\(s\) resent")


def check_stream_run(output, errlog, names, rc, started, ended):
    """Lost, duplicated and out-of-order frames of one stream run's JSON Lines."""
    run = {"output": output, "exit": rc, "expected": len(names), "records": 0, "lost": 0,
           "duplicated": 0, "out_of_order": 0, "not_ok": 0, "bad_name": 0, "resent": 0,
           "connections": 1, "retries": 0, "max_attempts": 0, "started": started,
           "ended": ended}
    seen = collections.Counter()
    order = []
    try:
        with open(output) as f:
            for line in f:
                if not line.strip():
                    continue
                r = json.loads(line)
                run["records"] += 1
                fid = r.get("frame_id")
                seen[fid] += 1
                order.append(fid)
                if r.get("status") != "OK":
                    run["not_ok"] += 1
                if isinstance(fid, int) and 0 <= fid < len(names) and r.get("frame") != names[fid]:
                    run["bad_name"] += 1
                run["max_attempts"] = max(run["max_attempts"], r.get("attempts", 0))
    except (OSError, ValueError) as e:
        run["error"] = str(e)
    run["lost"] = sum(1 for i in range(len(names)) if seen[i] == 0)
    run["duplicated"] = sum(c - 1 for c in seen.values() if c > 1)
    run["out_of_order"] = sum(1 for a, b in zip(order, order[1:]) if b != a + 1)
    try:
        text = open(errlog).read()
        run["retries"] = text.count("; reconnecting in ")
        m = SUMMARY.search(text)
        if m:
            run["connections"] = int(m.group(4))
            run["resent"] = int(m.group(5))
    except OSError:
        pass
    return run


def render_stream_frames(lane, out, frames_per_run):
    """Rendered JPEGs for the streams, listed frames_per_run times in all: (list file, names)."""
    frames_dir = os.path.join(out, "frames")
    subprocess.run([lane, "render", "--config", os.path.join(REPO, "configs", "synthetic.json"),
                    "--count", "20", "--seed", "7", "--format", "jpg", "--output", frames_dir],
                   check=True, stdout=subprocess.DEVNULL)
    files = sorted(f for f in os.listdir(frames_dir) if f.endswith(".jpg"))
    names = [files[i % len(files)] for i in range(frames_per_run)]
    list_file = os.path.join(frames_dir, "run.txt")
    with open(list_file, "w") as f:
        f.write("\n".join(names) + "\n")
    return list_file, names


class Cluster:
    """The replicas, the load on them, the fault schedule and what happened on the way."""

    def __init__(self, args, bins, out, deadline):
        self.args, self.bins, self.out, self.deadline = args, bins, out, deadline
        ports = free_ports(2 * args.replicas)
        self.replicas = [Replica(i, bins["server"], ports[2 * i], ports[2 * i + 1], out, deadline)
                         for i in range(args.replicas)]
        self.targets = [r.target for r in self.replicas]
        self.failures, self.loops, self.events = [], [], []
        self.bench = self.bench_rc = None
        self.stop_scraping = threading.Event()
        self.phase1 = []  # frames each replica received before the SIGTERM; [] when it failed
        self.elapsed = 0
        self.t0 = self.total = self.term_at = self.kill_at = self.victim = self.killed = None

    def run(self, list_file, names):
        """Starts the replicas and the load, runs the fault schedule and stops everything."""
        try:
            self.start_replicas()
            self.start_load(list_file, names)
            self.fault_schedule()
            self.wait_for_load()
        except RuntimeError:
            self.elapsed, self.bench_rc, self.events, self.phase1 = 0, None, [], []
        finally:
            self.shutdown()

    def scraper(self):
        """Scrapes every replica's /metrics every 0.5 s until stopped."""
        while not self.stop_scraping.is_set():
            for r in self.replicas:
                r.scrape()
            self.stop_scraping.wait(0.5)

    def start_replicas(self):
        """Starts the replicas, waits until they serve and starts the scraper."""
        for r in self.replicas:
            r.start()
        if not wait_healthy(self.bins["client"], self.targets, 20):
            self.failures.append("the replicas did not become healthy")
            raise RuntimeError("start-up")
        log("%d replicas up: gRPC %s, metrics %s" % (
            len(self.replicas), " ".join(self.targets),
            " ".join(str(r.metrics_port) for r in self.replicas)))
        threading.Thread(target=self.scraper, daemon=True).start()

    def start_load(self, list_file, names):
        """Starts lane-client bench (open loop, round_robin) and the stream loops."""
        args, out = self.args, self.out
        rr_target = "ipv4:" + ",".join(self.targets)  # one channel, round_robin over every replica
        warmup = 1.0
        self.total = warmup + args.duration
        bench_cmd = [self.bins["client"], "bench", "--target", rr_target, "--connections", "1",
                     "--cameras", str(args.cameras), "--fps", str(args.fps),
                     "--warmup", "%gs" % warmup, "--duration", "%gs" % args.duration,
                     "--drain-timeout", "5s", "--synthetic", "20", "--json",
                     "--output", os.path.join(out, "bench.json")]
        log("+ " + " ".join(bench_cmd[1:]))
        self.t0 = time.monotonic()
        self.bench = subprocess.Popen(bench_cmd, stdout=subprocess.DEVNULL,
                                      stderr=open(os.path.join(out, "bench.log"), "w"))
        for i in range(args.streams):
            loop = StreamLoop(i, self.bins["client"], self.targets, list_file, names, out)
            self.loops.append(loop)
            loop.start()

    def at(self, fraction):
        """Sleeps until that fraction of the bench's whole time."""
        delay = self.t0 + fraction * self.total - time.monotonic()
        if delay > 0:
            time.sleep(delay)

    def busiest(self, candidates):
        """The replica answering the most frames over the last 0.3 s: the
        stream loops dominate that, so stopping it interrupts streams."""
        before = []
        for r in candidates:
            r.scrape()
            before.append(r.incarnations[-1]["last"]["frames_ok"])
        time.sleep(0.3)
        rates = []
        for r, b in zip(candidates, before):
            r.scrape()
            rates.append(r.incarnations[-1]["last"]["frames_ok"] - b)
        return candidates[rates.index(max(rates))]

    def fault_schedule(self):
        """SIGTERM to the busiest replica at 40 %, SIGKILL and restart of another at 65 %."""
        t0, events, failures, deadline = self.t0, self.events, self.failures, self.deadline
        # Phase 1 ends: the spread over all replicas, before anything is stopped.
        self.at(0.4)
        self.victim = victim = self.busiest(self.replicas)
        # Frames received, not answered: on a loaded machine (CI shares its
        # cores; the ASan build is 3-5x slower) answers can lag the balancing
        # by seconds, and the spread checked is the client's.
        self.phase1 = [r.totals()["received"] for r in self.replicas]
        victim.proc.send_signal(signal.SIGTERM)
        self.term_at = term_at = time.monotonic()
        events.append("t=%.1fs SIGTERM replica %d (%s)" % (term_at - t0, victim.index,
                                                          victim.target))
        log(events[-1])

        self.at(0.65)
        self.killed = killed = self.busiest([r for r in self.replicas if r is not victim])
        killed.proc.kill()
        killed.proc.wait()
        killed.incarnations[-1]["exit"] = "SIGKILL"
        self.kill_at = time.monotonic()
        events.append("t=%.1fs SIGKILL replica %d (%s)" % (time.monotonic() - t0, killed.index,
                                                          killed.target))
        log(events[-1])
        time.sleep(1.0)
        killed.start()
        if wait_healthy(self.bins["client"], [killed.target], 15):
            events.append("t=%.1fs replica %d restarted and SERVING" % (
                time.monotonic() - t0, killed.index))
        else:
            failures.append("replica %d did not come back after the restart" % killed.index)
            events.append("replica %d did not come back" % killed.index)
        log(events[-1])

        # Replica 0: a drain ends by itself within the deadline (+ ~1.5 s for the
        # metrics endpoint).
        try:
            rc = victim.proc.wait(timeout=max(0.0, term_at + deadline + 5 - time.monotonic()))
            victim.incarnations[-1]["exit"] = rc
            events.append("replica %d drained and exited with status %d (waited for at "
                          "t=%.1fs)" % (victim.index, rc, time.monotonic() - t0))
            if rc != 0:
                failures.append("replica %d exited with %d after SIGTERM" % (victim.index, rc))
        except subprocess.TimeoutExpired:
            failures.append("replica %d did not exit within %d s of SIGTERM" % (
                victim.index, deadline + 5))
            victim.proc.kill()

    def wait_for_load(self):
        """Waits for the bench, stops the stream loops and scrapes a last time."""
        try:
            self.bench_rc = self.bench.wait(timeout=self.total + 30)
        except subprocess.TimeoutExpired:
            self.bench.kill()
            self.bench_rc = "timeout"
            self.failures.append("lane-client bench did not finish")
        for loop in self.loops:
            loop.stop.set()
        for loop in self.loops:
            loop.join(timeout=150)
        self.elapsed = time.monotonic() - self.t0
        for r in self.replicas:
            r.scrape()

    def shutdown(self):
        """Stops the scraper, the bench and every replica still running."""
        self.stop_scraping.set()
        if self.bench is not None and self.bench.poll() is None:
            self.bench.kill()
        for r in self.replicas:
            if r.proc is not None and r.proc.poll() is None:
                r.proc.send_signal(signal.SIGTERM)
        for r in self.replicas:
            if r.proc is not None:
                try:
                    r.proc.wait(timeout=self.deadline + 5)
                except subprocess.TimeoutExpired:
                    r.proc.kill()


RUN_SUMS = ("lost", "duplicated", "out_of_order", "not_ok", "bad_name", "expected", "records", "resent")


def collect_results(loops):
    """The stream runs of every loop, their sums, and the runs that reconnected or failed."""
    runs = [run for loop in loops for run in loop.runs]
    res = {key: sum(r[key] for r in runs) for key in RUN_SUMS}
    res["runs"] = runs
    res["reconnected"] = [r for r in runs if r["connections"] > 1 or r["retries"] > 0]
    res["failed_runs"] = [r for r in runs if r["exit"] != 0]
    return res


def print_report(c, res):
    """The report: the events, the streams' exactly-once figures, the bench's, each replica's."""
    runs = res["runs"]
    open_at = lambda t: sum(1 for r in runs if r["started"] < t < r["ended"])
    print("local-cluster report (%s, %.0f s)" % ("short" if c.args.short else "full", c.elapsed))
    print("  replicas: " + ", ".join("%d=%s (metrics :%d)" % (r.index, r.target, r.metrics_port)
                                     for r in c.replicas))
    for e in c.events:
        print("  " + e)
    print("exactly-once (lane-client stream, round_robin over ipv4:%s (rotated per run), "
          "%d loops):" % (",".join(c.targets), len(c.loops)))
    print("  runs %d, frames %d, records %d: lost %d, duplicated %d, out of order %d, "
          "not OK %d, wrong name %d" % (len(runs), res["expected"], res["records"], res["lost"],
                                        res["duplicated"], res["out_of_order"], res["not_ok"],
                                        res["bad_name"]))
    print("  runs open at the SIGTERM %d, at the SIGKILL %d; runs that retried or reconnected %d "
          "(%d frames resent, max attempts %d); runs failed %d" % (
              open_at(c.term_at), open_at(c.kill_at), len(res["reconnected"]), res["resent"],
              max([r["max_attempts"] for r in runs] or [0]), len(res["failed_runs"])))
    try:
        b = json.load(open(os.path.join(c.out, "bench.json")))
        run = b["runs"][0]
        print("load (lane-client bench, open loop %d cameras x %g fps, %g s, exit %s):" % (
            run["cameras"], c.args.fps, c.args.duration, c.bench_rc))
        print("  scheduled %d sent %d ok %d errors %s dropped %d unsent %d stream failures %d; "
              "p50 %.1f p99 %.1f ms" % (
                  run["frames_scheduled"], run["frames_sent"], run["frames_ok"],
                  json.dumps(run["errors"]) if run["errors"] else 0, run["dropped"],
                  run["unsent"], run["stream_failures"], run["latency_ms"]["p50"],
                  run["latency_ms"]["p99"]))
        print("  (bench does not resend: frames on a killed call count as errors or unsent;"
              " the exactly-once check is the streams')")
        if c.bench_rc not in (0, 3):
            c.failures.append("lane-client bench exited with %s" % c.bench_rc)
    except (OSError, ValueError, KeyError, IndexError) as e:
        c.failures.append("no bench report: %s" % e)

    print("per replica, from /metrics (last scrape of each process; frames answered OK):")
    total_ok = sum(r.totals()["frames_ok"] for r in c.replicas) or 1
    for r, p1 in zip(c.replicas, c.phase1):
        t = r.totals()
        per_inc = " + ".join("%d" % inc["last"]["frames_ok"] for inc in r.incarnations)
        print("  replica %d %s: ok %6d (%4.1f %%)%s  received %d, dropped %d, error+invalid %d, "
              "StreamFrames ended OK %d / UNAVAILABLE %d / CANCELLED %d; received before the SIGTERM %d" % (
                  r.index, r.target, t["frames_ok"], 100.0 * t["frames_ok"] / total_ok,
                  " (" + per_inc + " by process)" if len(r.incarnations) > 1 else "",
                  t["received"], t["frames_dropped"], t["frames_error"] + t["frames_invalid"],
                  t["streams_OK"], t["streams_UNAVAILABLE"], t["streams_CANCELLED"], p1))


def verdict(c, res):
    """The checks and notes, report.json, PASS or FAIL; the exit status."""
    failures, phase1 = c.failures, c.phase1
    lost, dup, reorder = res["lost"], res["duplicated"], res["out_of_order"]
    if lost or dup or reorder:
        failures.append("%d lost, %d duplicated, %d out-of-order stream frames" % (lost, dup, reorder))
    if res["not_ok"] or res["bad_name"]:
        failures.append("%d stream frames not OK, %d under the wrong name" % (res["not_ok"],
                                                                            res["bad_name"]))
    if res["failed_runs"]:
        failures.append("%d stream runs failed (exit status), e.g. %s" % (
            len(res["failed_runs"]), res["failed_runs"][0]["output"]))
    if not res["runs"]:
        failures.append("no stream run completed")
    phase1_total = sum(phase1)
    if phase1_total == 0 or min(phase1) < 0.10 * phase1_total:
        failures.append("load not spread before the SIGTERM (frames received): %s" % phase1)
    else:
        print("spread before the SIGTERM: %s frames received, smallest share %.0f %% (>= 10 %% "
              "required)"
              % ("/".join("%d" % v for v in phase1), 100.0 * min(phase1) / phase1_total))
    if c.killed.incarnations[-1]["last"]["frames_ok"] == 0:
        print("note: the restarted replica answered no frame: open streams stay on their pod "
              "(stream affinity); only new calls reach it")
    if not res["reconnected"]:
        print("note: no stream run was interrupted this time (the replicas stopped held none)")

    summary = {"lost": lost, "duplicated": dup, "out_of_order": reorder,
               "stream_runs": len(res["runs"]), "stream_frames": res["expected"],
               "resent": res["resent"], "reconnected_runs": len(res["reconnected"]),
               "phase1_ok": phase1, "ok_by_replica": [r.totals()["frames_ok"] for r in c.replicas],
               "failures": failures}
    json.dump(summary, open(os.path.join(c.out, "report.json"), "w"), indent=1)
    if failures:
        for f in failures:
            print("FAIL: " + f)
        return 1
    print("PASS: every stream frame answered exactly once, in order; load spread over %d replicas"
          % len(c.replicas))
    return 0


def main():
    args = parse_args()
    bins = binaries()
    out = os.path.abspath(args.out)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    deadline = 3 if args.short else 5
    list_file, names = render_stream_frames(bins["lane"], out, args.frames_per_run)
    cluster = Cluster(args, bins, out, deadline)
    cluster.run(list_file, names)
    if not cluster.phase1:
        print("\n".join("FAIL: " + f for f in cluster.failures))
        return 1
    res = collect_results(cluster.loops)
    print_report(cluster, res)
    return verdict(cluster, res)


if __name__ == "__main__":
    sys.exit(main())

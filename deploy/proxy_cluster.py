#!/usr/bin/python3
"""Streams across replicas, through a real proxy (deploy/proxy-cluster.sh is
the entry point; docs/deployment.md quotes its figures).

  * REPLICAS lane-server processes on 127.0.0.1 (--max_connection_age, so
    that long streams rebalance), behind Debian's nginx with
    deploy/nginx/lane-proxy.conf.template: consistent hashing of the
    x-camera-id header.
  * CAMERAS rendered drives (lane render --sequence), each streamed through
    the proxy by `lane-client stream` at the camera's rate, with tracking.
  * Under that load: the replica holding the most cameras is stopped with
    SIGTERM (it drains) and restarted; later the one then holding the most
    is killed with SIGKILL and restarted; later a new replica starts and is
    added to the proxy's list (nginx -s reload: nginx's old worker sends
    GOAWAY, the clients reconnect to the new one). With --spare-slot the
    proxy lists the fourth replica from the start instead, as a
    StatefulSet's nginx can list its pods up to the scale-out limit: nginx
    skips a slot that refuses connections (its cameras on their next
    replica of the ring) and gives them back once it answers.
  * Placement is measured with PROBE extra camera ids (CreateSession through
    the proxy, before and after the new replica): how many move.

Checks (exit status 1 when one fails, 2 for a bad command line or a missing
program):
  * every frame of every camera is answered exactly once, in order;
  * before the first fault each camera's frames went to one replica;
  * lane ids: of the true boundaries a stream carried across its
    reconnections, at least 95 % keep their id (id switches beyond those of
    the same drive tracked in one process, `lane detect --track`, over the
    boundaries present at the reconnections), and no lane id is given to a
    second boundary more often than in that reference;
  * adding the replica moves at most 40 % of the probe cameras.
"""

import argparse
import collections
import glob
import json
import os
import signal
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from local_cluster import REPO, binaries, free_ports, parse_metrics, wait_healthy  # noqa: E402

CONFIG = os.path.join(REPO, "configs", "synthetic.json")


def log(message):
    print("proxy-cluster: " + message, file=sys.stderr, flush=True)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cameras", type=int, default=6, help="streaming cameras (default 6)")
    p.add_argument("--frames", type=int, default=240,
                   help="frames of each camera's drive (default 240: 8 s at 30/s)")
    p.add_argument("--fps", type=float, default=30.0, help="each camera's rate (default 30)")
    p.add_argument("--replicas", type=int, default=3, help="replicas at the start (default 3)")
    p.add_argument("--max-age", type=float, default=2.0,
                   help="lane-server --max_connection_age, s (default 2)")
    p.add_argument("--resume-state-every", type=int, default=15,
                   help="lane-server --resume_state_every (default 15; 0 shows what the "
                   "resume state is worth: the id check then fails)")
    p.add_argument("--spare-slot", action="store_true",
                   help="list the added replica in the proxy from the start instead of "
                   "reloading nginx with it")
    p.add_argument("--probe", type=int, default=200,
                   help="camera ids whose placement is measured (default 200)")
    p.add_argument("--out", default=os.environ.get("OUT", "out/proxy-cluster"),
                   help="work and log folder (default out/proxy-cluster, or $OUT)")
    args = p.parse_args()
    if args.replicas < 3 or args.cameras < 1 or args.frames < 60:
        p.error("--replicas >= 3, --cameras >= 1, --frames >= 60")
    return args


def shared_key_file(out):
    """The replicas' resume-state key: made once per run, mode 0600."""
    path = os.path.join(out, "resume-state.key")
    if not os.path.exists(path):
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w") as f:
            f.write(os.urandom(32).hex() + "\n")
    return path


class Replica:
    def __init__(self, index, server, port, metrics_port, out, args):
        self.index, self.server, self.port, self.metrics_port = index, server, port, metrics_port
        self.out, self.max_age, self.every = out, args.max_age, args.resume_state_every
        self.key_file = shared_key_file(out)
        self.proc = None
        self.starts = 0
        self.scrapes = []  # (incarnation, metrics) of the last scrape of each incarnation

    @property
    def address(self):
        return "127.0.0.1:%d" % self.port

    def start(self):
        logf = open(os.path.join(self.out, "replica-%d.%d.log" % (self.index, self.starts)), "w")
        self.proc = subprocess.Popen(
            [self.server, "--address=" + self.address,
             "--metrics_address=127.0.0.1:%d" % self.metrics_port,
             "--workers=1", "--metrics_camera_labels=4096", "--shutdown_deadline=10s",
             "--max_sessions=1024",
             "--max_connection_age=%gs" % self.max_age, "--max_connection_age_grace=10s",
             "--resume_state_every=%d" % self.every,
             # Every replica holds the same resume-state key, as a
             # deployment's Secret gives them (docs/deployment.md).
             "--resume_state_key_file=" + self.key_file],
            stdout=logf, stderr=subprocess.STDOUT)
        self.starts += 1

    def metrics(self):
        r = subprocess.run(["curl", "-s", "--max-time", "2",
                            "http://127.0.0.1:%d/metrics" % self.metrics_port],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        return parse_metrics(r.stdout) if r.returncode == 0 else {}

    def camera_frames(self):
        """{camera: frames answered} on this incarnation."""
        out = collections.Counter()
        for (name, labels), value in self.metrics().items():
            if name == "lanesvc_camera_frames_total" and 'camera="' in labels:
                out[labels.split('camera="')[1].split('"')[0]] += value
        return out

    def resumes(self):
        out = collections.Counter()
        for (name, labels), value in self.metrics().items():
            if name == "lanesvc_stream_resumes_total":
                out[labels.split('outcome="')[1].split('"')[0]] += value
            if name == "lanesvc_resume_state_bytes_count":
                out["states"] += value
            if name == "lanesvc_resume_state_bytes_sum":
                out["state_bytes"] += value
        return out


class Proxy:
    def __init__(self, out, port):
        self.dir = os.path.join(out, "nginx")
        self.port = port
        os.makedirs(self.dir, exist_ok=True)
        self.conf = os.path.join(self.dir, "nginx.conf")
        self.proc = None

    def write(self, replicas):
        with open(os.path.join(REPO, "deploy", "nginx", "lane-proxy.conf.template")) as f:
            text = f.read()
        servers = "\n".join("    server %s max_fails=1 fail_timeout=2s;" % r.address
                            for r in replicas)
        text = (text.replace("@LISTEN@", "127.0.0.1:%d" % self.port)
                .replace("@SERVERS@", servers).replace("@PREFIX@", self.dir))
        with open(self.conf, "w") as f:
            f.write(text)

    def reload(self, nginx):
        subprocess.run([nginx, "-t", "-q", "-c", self.conf, "-p", self.dir], check=True)
        self.proc.send_signal(signal.SIGHUP)

    def start(self, nginx):
        subprocess.run([nginx, "-t", "-q", "-c", self.conf, "-p", self.dir], check=True)
        self.proc = subprocess.Popen([nginx, "-c", self.conf, "-p", self.dir, "-g", "daemon off;"])

    @property
    def target(self):
        return "127.0.0.1:%d" % self.port


def render(lane, out, cameras, frames):
    """One drive per camera (seeds 101...), two at a time."""
    drives = []
    procs = []
    for c in range(cameras):
        d = os.path.join(out, "drive-%d" % c)
        drives.append(d)
        if os.path.isfile(os.path.join(d, "list.txt")) and \
                len(glob.glob(os.path.join(d, "*.jpg"))) == frames:
            continue
        procs.append(subprocess.Popen(
            [lane, "render", "--config", CONFIG, "--sequence", "--count", str(frames),
             "--seed", str(101 + c), "--output", d, "--format", "jpg"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        if len(procs) >= 2:
            if procs.pop(0).wait() != 0:
                raise RuntimeError("lane render failed")
    for p in procs:
        if p.wait() != 0:
            raise RuntimeError("lane render failed")
    return drives


def probe_placement(client, proxy_target, replicas, cameras):
    """Creates a session for each probe camera through the proxy and returns
    {camera: replica index} from each replica's ListSessions."""
    placement = {}
    procs = []
    for cam in cameras:
        procs.append(subprocess.Popen(
            [client, "session", "create", "--target", proxy_target, "--camera", cam,
             "--config", CONFIG], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        if len(procs) >= 8:
            procs.pop(0).wait()
    for p in procs:
        p.wait()
    wanted = set(cameras)
    for r in replicas:
        if r.proc is None or r.proc.poll() is not None:
            continue
        out = subprocess.run([client, "session", "list", "--target", r.address],
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout
        for line in out.splitlines():
            try:
                sessions = json.loads(line).get("sessions", [])
            except ValueError:
                continue
            for s in sessions:
                cam = s.get("cameraId") or s.get("camera_id")
                if cam in wanted and cam not in placement:
                    placement[cam] = r.index
    return placement


# --- scoring lane ids against the drives' truth --------------------------------

def bezier_x_at(points, row):
    """x of a cubic Bezier (4 image points) at image row `row`, or None."""
    best = None
    for i in range(101):
        t = i / 100.0
        u = 1 - t
        x = u**3 * points[0][0] + 3 * u * u * t * points[1][0] + 3 * u * t * t * points[2][0] \
            + t**3 * points[3][0]
        y = u**3 * points[0][1] + 3 * u * u * t * points[1][1] + 3 * u * t * t * points[2][1] \
            + t**3 * points[3][1]
        if best is None or abs(y - row) < best[0]:
            best = (abs(y - row), x)
    return best[1] if best and best[0] <= 3 else None


def matches(truth, lanes, height):
    """{true boundary id: lane id} for the confirmed lanes within 25 px of a
    true boundary at 62 % of the image height (inside the
    synthetic camera's top view, rows 220-350 of 480) (one to one, nearest first)."""
    row = 0.62 * height
    pairs = []
    for b in truth:
        bx = bezier_x_at(b["points"], row)
        if bx is None:
            continue
        for lane in lanes:
            if not lane.get("confirmed") or lane.get("id", 0) <= 0:
                continue
            lx = bezier_x_at(lane["image"], row)
            if lx is not None and abs(lx - bx) < 25:
                pairs.append((abs(lx - bx), b["id"], lane["id"]))
    out, used = {}, set()
    for _, b, lid in sorted(pairs):
        if b not in out and lid not in used:
            out[b] = lid
            used.add(lid)
    return out


def id_story(drive, results_path):
    """Per frame {boundary: lane id}, id switches, and ids given to a second
    boundary, for one results file."""
    truth = [json.loads(l) for l in open(os.path.join(drive, "labels.jsonl"))]
    rows = [json.loads(l) for l in open(results_path)]
    frames = []
    for t, r in zip(truth, rows):
        frames.append(matches(t["boundaries"], r.get("lanes", []), t["height"]))
    switches = 0
    last = {}
    owner = {}  # lane id -> boundaries it was matched to (frames)
    for m in frames:
        for b, lid in m.items():
            if b in last and last[b] != lid:
                switches += 1
            last[b] = lid
            owner.setdefault(lid, collections.Counter())[b] += 1
    reused = sum(1 for c in owner.values() if len([n for n in c.values() if n >= 3]) > 1)
    return frames, switches, reused


def reconnect_frames(results_path):
    """Frames answered first on a new call (lane-client's `connection`)."""
    rows = [json.loads(l) for l in open(results_path)]
    return [i for i in range(1, len(rows))
            if rows[i].get("connection", 0) != rows[i - 1].get("connection", 0)]


def track_references(lane, out, drives):
    """Each drive tracked in one process (lane detect --track): the reference."""
    for c, d in enumerate(drives):
        subprocess.run([lane, "detect", "--config", CONFIG, "--track",
                        os.path.join(d, "list.txt"), "--output",
                        os.path.join(out, "reference-%d.jsonl" % c)],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def start_cluster(args, bins, nginx, replicas, proxy):
    """Starts the first REPLICAS replicas and the proxy; False when one of
    them does not pass its health checks."""
    live = replicas[:args.replicas]
    for r in live:
        r.start()
    proxy.write(replicas if args.spare_slot else live)  # a spare slot is down for now
    proxy.start(nginx)
    for r in live:
        if not wait_healthy(bins["client"], [r.address], 20):
            log("replica %d did not start" % r.index)
            return False
    if not wait_healthy(bins["client"], [proxy.target], 20):
        log("the proxy did not pass health checks")
        return False
    return True


def start_streams(args, client, target, out, drives, cams):
    streams = []
    for c, d in enumerate(drives):
        errf = open(os.path.join(out, "stream-%d.err" % c), "w")
        streams.append(subprocess.Popen(
            [client, "stream", "--target", target, "--camera", cams[c],
             "--config", CONFIG, "--fps", str(args.fps), "--window", "4", "--no-progress",
             "--output", os.path.join(out, "stream-%d.jsonl" % c),
             os.path.join(d, "list.txt")], stdout=subprocess.DEVNULL, stderr=errf))
    return streams


def camera_affinity(live, cams, failures):
    """Which replicas each streaming camera's frames went to; a failure when
    a camera is on more than one replica, or on none."""
    per_camera = collections.defaultdict(set)
    for r in live:
        for cam, n in r.camera_frames().items():
            if cam in cams and n > 0:
                per_camera[cam].add(r.index)
    split = [c for c, rs in per_camera.items() if len(rs) > 1]
    affinity = {c: sorted(rs) for c, rs in per_camera.items()}
    if split or len(per_camera) < len(cams):
        failures.append("before the faults, cameras on more than one replica (or none): %s"
                        % affinity)
    return affinity


def stream_through_faults(args, bins, nginx, replicas, proxy, drives, failures):
    """The cameras stream through the proxy while a replica drains, one is
    killed and a new one is added. What the checks need, as a dict."""
    live = replicas[:args.replicas]
    probes = ["probe-%03d" % i for i in range(args.probe)]
    before = probe_placement(bins["client"], proxy.target, live, probes)
    cams = ["cam-%d" % c for c in range(args.cameras)]
    streams = start_streams(args, bins["client"], proxy.target, args.out_abs, drives, cams)
    t0 = time.monotonic()
    duration = args.frames / args.fps

    def at(fraction):
        wait = t0 + fraction * duration - time.monotonic()
        if wait > 0:
            time.sleep(wait)

    def holder(exclude=()):
        counts = {r.index: len(r.camera_frames()) for r in live if r.index not in exclude}
        return max(counts, key=counts.get)

    # Affinity before any fault (and before the first --max_connection_age).
    at(0.15)
    affinity = camera_affinity(live, cams, failures)
    at(0.2)
    a = holder()
    log("SIGTERM replica %d (it drains)" % a)
    replicas[a].proc.send_signal(signal.SIGTERM)
    replicas[a].proc.wait(timeout=30)
    at(0.35)
    replicas[a].start()
    at(0.45)
    b = holder(exclude=(a,))
    log("SIGKILL replica %d" % b)
    replicas[b].proc.kill()
    replicas[b].proc.wait()
    at(0.5)
    replicas[b].start()
    at(0.6)
    new = replicas[args.replicas]
    new.start()
    wait_healthy(bins["client"], [new.address], 20)
    live = replicas[:args.replicas + 1]
    if args.spare_slot:
        log("replica %d started in the proxy's spare slot" % new.index)
        time.sleep(2.5)  # the slot's fail_timeout: nginx tries it again
    else:
        log("adding replica %d to the proxy (nginx -s reload)" % new.index)
        proxy.write(live)
        proxy.reload(nginx)
        time.sleep(0.5)
    after = probe_placement(bins["client"], proxy.target, live, probes)
    run = {"affinity": affinity, "new": new, "probed": len(before)}
    run["moved"] = sum(1 for cam in probes if cam in before and after.get(cam) != before[cam])
    run["to_new"] = sum(1 for cam in probes if after.get(cam) == new.index)
    run["rcs"] = [s.wait(timeout=duration + 120) for s in streams]
    run["resumes"] = collections.Counter()
    for r in live:
        run["resumes"].update(r.resumes())
    run["cams_on_new"] = sorted(c for c in cams if new.camera_frames().get(c, 0) > 0)
    return run


def stop_cluster(replicas, proxy):
    for r in replicas:
        if r.proc is not None and r.proc.poll() is None:
            r.proc.terminate()
    if proxy.proc is not None:
        proxy.proc.terminate()
    for r in replicas:
        if r.proc is not None:
            try:
                r.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                r.proc.kill()


def check_frames(args, out, rcs, failures):
    """Exactly once, in order: (lost, duplicated) frames."""
    lost = dup = 0
    for c in range(args.cameras):
        path = os.path.join(out, "stream-%d.jsonl" % c)
        ids = [json.loads(l)["frame_id"] for l in open(path)] if os.path.exists(path) else []
        if rcs[c] != 0:
            failures.append("camera %d: lane-client exited with %d (%s)"
                            % (c, rcs[c], os.path.join(out, "stream-%d.err" % c)))
        if ids != list(range(args.frames)):
            lost += len(set(range(args.frames)) - set(ids))
            dup += len(ids) - len(set(ids))
            failures.append("camera %d: frames not answered exactly once in order "
                            "(%d answers)" % (c, len(ids)))
    return lost, dup


def check_ids(out, drives, failures):
    """Lane ids across the reconnections, against the one-process reference."""
    ids = {"carried": 0, "extra_switches": 0, "extra_reused": 0, "rows": []}
    for c, d in enumerate(drives):
        path = os.path.join(out, "stream-%d.jsonl" % c)
        if not os.path.exists(path):
            continue
        frames, switches, reused = id_story(d, path)
        _, ref_switches, ref_reused = id_story(d, os.path.join(out, "reference-%d.jsonl" % c))
        at_reconnect = reconnect_frames(path)
        n = sum(len(frames[i - 1]) for i in at_reconnect if i - 1 < len(frames))
        ids["carried"] += n
        ids["extra_switches"] += max(0, switches - ref_switches)
        ids["extra_reused"] += max(0, reused - ref_reused)
        ids["rows"].append((c, len(at_reconnect), n, switches, ref_switches, reused, ref_reused))
    carried = ids["carried"]
    ids["kept"] = kept = 1.0 - ids["extra_switches"] / carried if carried else 1.0
    if carried == 0:
        failures.append("no boundary was carried across a reconnection: nothing was tested")
    if kept < 0.95:
        failures.append("only %.1f %% of the boundaries kept their id across reconnections"
                        % (100 * kept))
    if ids["extra_reused"] > 0:
        failures.append("%d lane ids were given to a second boundary more often than in the "
                        "reference" % ids["extra_reused"])
    return ids


def report(args, run, lost, dup, ids, moved_share, started, failures):
    print("# proxy-cluster: %d replicas + 1 added, nginx (consistent hash of x-camera-id), "
          "%d cameras x %d frames at %g/s, --max_connection_age %gs"
          % (args.replicas, args.cameras, args.frames, args.fps, args.max_age))
    print("affinity before the faults: %s" % run["affinity"])
    print("frames: %d lost, %d duplicated" % (lost, dup))
    print("| camera | reconnections | boundaries carried | id switches | reference | ids reused "
          "| reference |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for row in ids["rows"]:
        print("| cam-%d | %d | %d | %d | %d | %d | %d |" % row)
    print("boundaries that kept their id across reconnections: %.1f %% (%d carried, %d extra "
          "switches)" % (100 * ids["kept"], ids["carried"], ids["extra_switches"]))
    resumes = run["resumes"]
    print("resumes on the replicas: %s" % dict(resumes))
    if resumes.get("states"):
        print("resume state: %.0f bytes on average over %d states"
              % (resumes["state_bytes"] / resumes["states"], resumes["states"]))
    print("adding replica %d: %d of %d probe cameras moved (%.0f %%, %d now on it); streaming "
          "cameras on it by the end: %s"
          % (run["new"].index, run["moved"], run["probed"], 100 * moved_share, run["to_new"],
             run["cams_on_new"]))
    print("time: %.0f s" % (time.monotonic() - started))
    for f in failures:
        print("FAILED: " + f)


def main():
    args = parse_args()
    bins = binaries()
    nginx = os.environ.get("NGINX", "/usr/sbin/nginx")
    if not os.access(nginx, os.X_OK):
        log("nginx is missing (apt-get install nginx; scripts/install-deps.sh)")
        return 2
    out = args.out_abs = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    n_total = args.replicas + 1
    ports = free_ports(2 * n_total + 1)
    replicas = [Replica(i, bins["server"], ports[2 * i], ports[2 * i + 1], out, args)
                for i in range(n_total)]
    proxy = Proxy(out, ports[-1])
    started = time.monotonic()
    failures = []

    log("rendering %d drives of %d frames" % (args.cameras, args.frames))
    drives = render(bins["lane"], out, args.cameras, args.frames)
    log("reference: each drive tracked in one process (lane detect --track)")
    track_references(bins["lane"], out, drives)
    try:
        if not start_cluster(args, bins, nginx, replicas, proxy):
            return 1
        run = stream_through_faults(args, bins, nginx, replicas, proxy, drives, failures)
    finally:
        stop_cluster(replicas, proxy)

    lost, dup = check_frames(args, out, run["rcs"], failures)
    ids = check_ids(out, drives, failures)
    moved_share = run["moved"] / max(1, run["probed"])
    if moved_share > 0.40:
        failures.append("adding a replica moved %.0f %% of the probe cameras" % (100 * moved_share))
    report(args, run, lost, dup, ids, moved_share, started, failures)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

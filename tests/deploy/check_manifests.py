#!/usr/bin/python3
"""Offline checks of deploy/: the compose file, the Kubernetes manifests, the
Prometheus and Grafana files and the Dockerfile agree with each other and with
lane-server's flags (server/main.cc) and metrics (server/metrics.cc).

usage: check_manifests.py [REPO_ROOT]     (exit 0 pass, 1 fail, 77 skipped: no PyYAML)
"""

import glob
import json
import os
import re
import sys

try:
    import yaml
except ImportError:  # Debian: python3-yaml (scripts/install-deps.sh)
    print("SKIP: PyYAML is missing (apt-get install python3-yaml)")
    sys.exit(77)

ROOT = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                       os.path.join(os.path.dirname(__file__), "..", ".."))
DEPLOY = os.path.join(ROOT, "deploy")
failures = []
checks = 0


def check(condition, message):
    global checks
    checks += 1
    if not condition:
        failures.append(message)
    return condition


def read(path):
    with open(os.path.join(ROOT, path)) as f:
        return f.read()


def load_all(path):
    try:
        with open(path) as f:
            return [d for d in yaml.safe_load_all(f) if d is not None]
    except (OSError, yaml.YAMLError) as e:
        print("FAIL: %s does not parse as YAML: %s" % (os.path.relpath(path, ROOT), e))
        sys.exit(1)


def port_of(address):
    m = re.search(r":(\d+)$", address or "")
    return int(m.group(1)) if m else None


def seconds(text):
    """A duration as absl/Go write it: 10s, 1.5s, 500ms, 2m, 1m30s; or a number."""
    if isinstance(text, (int, float)):
        return float(text)
    total, rest = 0.0, text.strip()
    for value, unit in re.findall(r"(\d+(?:\.\d+)?)(ms|us|ns|h|m|s)", rest):
        total += float(value) * {"h": 3600, "m": 60, "s": 1, "ms": 1e-3, "us": 1e-6,
                                 "ns": 1e-9}[unit]
    return total


def flags_of(args):
    """--name=value arguments as a dict (the last occurrence wins, as in abseil)."""
    out = {}
    for a in args or []:
        m = re.match(r"^--?([a-z][a-z_-]*)(?:=(.*))?$", str(a))
        if m:
            out[m.group(1)] = m.group(2) if m.group(2) is not None else "true"
    return out


# ---- lane-server's defaults, from its source ----------------------------------
main_cc = read("server/main.cc")


def flag_default(name):
    m = re.search(r'ABSL_FLAG\([^,]+,\s*%s,\s*([^,]+(?:\([^)]*\))?)' % name, main_cc)
    assert m, "flag %s not found in server/main.cc" % name
    return m.group(1).strip()


DEFAULT_GRPC_PORT = port_of(flag_default("address").strip('"'))
DEFAULT_METRICS_PORT = port_of(flag_default("metrics_address").strip('"'))
m = re.match(r"absl::Seconds\((\d+)\)", flag_default("shutdown_deadline"))
DEFAULT_DEADLINE = float(m.group(1)) if m else None
check(DEFAULT_GRPC_PORT == 50051, "server/main.cc: --address default port is %s, the deploy "
      "files assume 50051" % DEFAULT_GRPC_PORT)
check(DEFAULT_METRICS_PORT == 9464, "server/main.cc: --metrics_address default port is %s, the "
      "deploy files assume 9464" % DEFAULT_METRICS_PORT)
check(DEFAULT_DEADLINE is not None, "server/main.cc: cannot read --shutdown_deadline's default")
SERVER_FLAGS = set(re.findall(r"ABSL_FLAG\([^,]+,\s*([a-z_]+),", main_cc))

metrics_cc = read("server/metrics.cc") + read("server/grpc_metrics.cc")
METRICS = set(re.findall(r'\.Name\("([a-z_]+)"\)', metrics_cc))
METRICS |= set(re.findall(r'NewMetrics[A-Za-z]+\(\s*registry,\s*"([a-z_]+)"', metrics_cc))
METRICS |= set(re.findall(r'Family\("(process_[a-z_]+)"', read("server/process_metrics.cc")))
METRICS |= set(re.findall(r'\.name = "([a-z_]+)"', read("server/calibration_metrics.cc")))
check({"lanesvc_frame_latency_seconds", "lanesvc_frames_total", "lanesvc_stage_duration_seconds",
       "lanesvc_sessions_active", "lanesvc_inflight_frames", "grpc_server_handled_total"}
      <= METRICS, "server/metrics.cc lacks a metric the dashboard needs: %s" % sorted(METRICS))


def check_server_flags(where, flags):
    for name in flags:
        check(name in SERVER_FLAGS, "%s: --%s is not a lane-server flag" % (where, name))


# ---- Dockerfile and its entry point -------------------------------------------
dockerfile = read("deploy/Dockerfile")
stages = re.findall(r"^FROM\s+(\S+)", dockerfile, re.M)
check(len(stages) >= 2, "Dockerfile: not multi-stage")
check(stages and "-slim" in stages[-1], "Dockerfile: the runtime stage is not a -slim image")
check(re.search(r"^USER\s+(?!0\b|root\b)\S+", dockerfile, re.M) is not None,
      "Dockerfile: no non-root USER")
expose = set(int(p) for line in re.findall(r"^EXPOSE\s+(.+)$", dockerfile, re.M)
             for p in line.split())
check({DEFAULT_GRPC_PORT, DEFAULT_METRICS_PORT} <= expose,
      "Dockerfile: EXPOSE %s lacks the gRPC or metrics port" % sorted(expose))
hc_text = re.search(r"^HEALTHCHECK(?:.*\\\n)*.*$", dockerfile, re.M)
check(hc_text and "lane-client health" in hc_text.group(0) and "LANE_GRPC_PORT" in hc_text.group(0),
      "Dockerfile: HEALTHCHECK does not run lane-client health on $LANE_GRPC_PORT")
env = dict(re.findall(r"\b(LANE_[A-Z_]+)=(\S+)", " ".join(
    re.findall(r"^ENV((?:.*\\\n)*.*)$", dockerfile, re.M))))
check(env.get("LANE_GRPC_PORT") == str(DEFAULT_GRPC_PORT), "Dockerfile: ENV LANE_GRPC_PORT")
check(env.get("LANE_METRICS_PORT") == str(DEFAULT_METRICS_PORT), "Dockerfile: ENV LANE_METRICS_PORT")
check(seconds(env.get("LANE_SHUTDOWN_DEADLINE", "")) == DEFAULT_DEADLINE,
      "Dockerfile: ENV LANE_SHUTDOWN_DEADLINE is not the server's default")
entrypoint = read("deploy/docker-entrypoint.sh")
for var, flag in (("LANE_GRPC_PORT", "address"), ("LANE_METRICS_PORT", "metrics_address"),
                  ("LANE_DEFAULT_CONFIG", "default_config"), ("LANE_WORKERS", "workers"),
                  ("LANE_SHUTDOWN_DEADLINE", "shutdown_deadline")):
    check(re.search(r"--%s=[^\"]*\$\{%s" % (flag, var), entrypoint) is not None,
          "docker-entrypoint.sh: %s does not set --%s" % (var, flag))
    check(var in env, "Dockerfile: no ENV %s" % var)
for src in re.findall(r"^COPY\s+(?!--from)(\S+)", dockerfile, re.M):
    check(os.path.exists(os.path.join(ROOT, src)), "Dockerfile: COPY %s: no such file" % src)
# Every folder the top-level CMakeLists.txt adds is copied into the build stage
# (tests, bench and fuzz are switched off there).
copied = set(s.rstrip("/") for s in re.findall(r"^COPY\s+(?!--from)(\S+)", dockerfile, re.M))
for sub in re.findall(r"^\s*add_subdirectory\((\w+)\)", read("CMakeLists.txt"), re.M):
    if sub not in ("tests", "bench", "fuzz"):
        check(sub in copied, "Dockerfile: the build needs %s/ but does not COPY it" % sub)
image_default_config = env.get("LANE_DEFAULT_CONFIG")
check(re.search(r"^COPY\s+configs/\S+\s+%s\s*$" % re.escape(image_default_config or "-"),
                dockerfile, re.M) is not None,
      "Dockerfile: LANE_DEFAULT_CONFIG=%s is not copied into the image" % image_default_config)

# Every file the Dockerfile copies from the context is let through by its
# .dockerignore ("*" then "!path" lines): a path left out fails the build.
with open(os.path.join(DEPLOY, "Dockerfile.dockerignore")) as f:
    allowed = [line.strip()[1:].rstrip("/") for line in f if line.strip().startswith("!")]
for line in dockerfile.splitlines():
    m = re.match(r"^COPY\s+(?!--from)(.*)$", line.strip())
    if not m:
        continue
    for source in m.group(1).split()[:-1]:
        source = source.rstrip("/")
        check(any(source == a or source.startswith(a + "/") for a in allowed),
              "Dockerfile: COPY %s, which Dockerfile.dockerignore leaves out of the context"
              % source)

# ---- compose ------------------------------------------------------------------
compose_path = os.path.join(DEPLOY, "compose.yaml")
(compose,) = load_all(compose_path)
services = compose.get("services", {})
check({"lane-server", "prometheus", "grafana"} <= set(services),
      "compose.yaml: services %s" % sorted(services))
server = services.get("lane-server", {})
compose_image = server.get("image")
# One version (VERSION): the image is tagged with it.
with open(os.path.join(ROOT, "VERSION")) as f:
    version = f.readline().strip()
check(compose_image == "lanedet/lane-server:%s" % version,
      "compose.yaml: image %s is not tagged with VERSION %s" % (compose_image, version))
compose_env = {k: str(v) for k, v in (server.get("environment") or {}).items()}
compose_flags = flags_of(server.get("command"))
check_server_flags("compose.yaml lane-server command", compose_flags)
grpc_port = int(compose_env.get("LANE_GRPC_PORT", env.get("LANE_GRPC_PORT")))
metrics_port = int(compose_env.get("LANE_METRICS_PORT", env.get("LANE_METRICS_PORT")))
if "address" in compose_flags:
    grpc_port = port_of(compose_flags["address"])
if "metrics_address" in compose_flags:
    metrics_port = port_of(compose_flags["metrics_address"])
check(grpc_port == DEFAULT_GRPC_PORT, "compose.yaml: lane-server gRPC port %s" % grpc_port)
check(metrics_port == DEFAULT_METRICS_PORT, "compose.yaml: metrics port %s" % metrics_port)
published = [str(p).split(":")[-1] for p in server.get("ports", [])]
check(str(grpc_port) in published and str(metrics_port) in published,
      "compose.yaml: lane-server ports %s do not publish %s and %s" % (published, grpc_port,
                                                                        metrics_port))
deadline = seconds(compose_flags.get("shutdown_deadline",
                                     compose_env.get("LANE_SHUTDOWN_DEADLINE", "%gs" % DEFAULT_DEADLINE)))
check(seconds(server.get("stop_grace_period", "10s")) > deadline,
      "compose.yaml: stop_grace_period must exceed the drain deadline (%g s)" % deadline)
build = server.get("build", {})
check(os.path.normpath(os.path.join(DEPLOY, build.get("context", "."), build.get("dockerfile", "")))
      == os.path.join(DEPLOY, "Dockerfile"), "compose.yaml: build does not use deploy/Dockerfile")
for name, svc in services.items():
    for volume in svc.get("volumes", []):
        src = str(volume).split(":")[0]
        if src.startswith("."):
            check(os.path.exists(os.path.join(DEPLOY, src)),
                  "compose.yaml: %s mounts %s, which does not exist" % (name, src))

# ---- Prometheus -----------------------------------------------------------------
(prom,) = load_all(os.path.join(DEPLOY, "prometheus", "prometheus.yml"))
lane_jobs = [j for j in prom.get("scrape_configs", []) if j.get("job_name") == "lane-server"]
check(len(lane_jobs) == 1, "prometheus.yml: no lane-server job")
for job in lane_jobs:
    check(job.get("metrics_path", "/metrics") == "/metrics", "prometheus.yml: metrics_path")
    targets = [t for sc in job.get("static_configs", []) for t in sc.get("targets", [])]
    check(targets, "prometheus.yml: the lane-server job has no target")
    for t in targets:
        host, _, port = t.rpartition(":")
        check(host in services, "prometheus.yml: target %s is not a compose service" % t)
        check(port == str(metrics_port), "prometheus.yml: target %s is not the metrics port %s"
              % (t, metrics_port))

# ---- Grafana --------------------------------------------------------------------
datasources = [d for f in glob.glob(os.path.join(DEPLOY, "grafana", "provisioning", "datasources", "*.y*ml"))
               for doc in load_all(f) for d in doc.get("datasources", [])]
check(any(d.get("type") == "prometheus" and "prometheus:9090" in d.get("url", "")
          for d in datasources), "grafana: no Prometheus datasource on prometheus:9090")
providers = [p for f in glob.glob(os.path.join(DEPLOY, "grafana", "provisioning", "dashboards", "*.y*ml"))
             for doc in load_all(f) for p in doc.get("providers", [])]
check(providers, "grafana: no dashboard provider")
grafana_mounts = {str(v).split(":")[1]: str(v).split(":")[0]
                  for v in services.get("grafana", {}).get("volumes", [])}
for p in providers:
    path = p.get("options", {}).get("path", "")
    check(path in grafana_mounts, "grafana: provider path %s is not mounted" % path)
dashboards = glob.glob(os.path.join(DEPLOY, "grafana", "dashboards", "*.json"))
check(dashboards, "grafana: no dashboard JSON")
exprs = []
for d in dashboards:
    with open(d) as f:
        dash = json.load(f)
    for panel in dash.get("panels", []):
        for target in panel.get("targets", []):
            exprs.append(target.get("expr", ""))
joined = "\n".join(exprs)
for needed, what in (
        (r"histogram_quantile\(0\.5, .*lanesvc_frame_latency_seconds_bucket", "latency p50"),
        (r"histogram_quantile\(0\.99, .*lanesvc_frame_latency_seconds_bucket", "latency p99"),
        (r"sum by \(result\) \(rate\(lanesvc_frames_total", "frames/s by result"),
        (r"by \(stage\).*lanesvc_stage_duration_seconds", "stage breakdown"),
        (r"lanesvc_sessions_active", "active sessions"),
        (r"lanesvc_inflight_frames", "in-flight frames"),
        (r"by \(grpc_method, grpc_code\).*grpc_server_handled_total", "errors by code")):
    check(re.search(needed, joined) is not None, "dashboard: no panel for %s" % what)
for name in re.findall(r"\b((?:lanesvc|grpc_server)_[a-z_]+)", joined):
    base = re.sub(r"_(bucket|sum|count)$", "", name)
    check(base in METRICS, "dashboard: %s is not a metric of server/metrics.cc" % name)

# ---- Alert rules (promtool checks them in ctest deploy_alert_rules) ----------------
alerts_text = read("deploy/prometheus/alerts.yml")
alert_rules = [r for g in yaml.safe_load(alerts_text)["groups"] for r in g["rules"]]
check(len(alert_rules) >= 8, "alerts.yml: only %d rules" % len(alert_rules))
for r in alert_rules:
    for name in re.findall(r"\b((?:lanesvc|grpc_server|process)_[a-z_]+)", r["expr"]):
        base = re.sub(r"_(bucket|sum|count)$", "", name)
        check(base in METRICS, "alerts.yml %s: %s is not a metric of lane-server" % (r["alert"], name))
check("alerts.yml" in json.dumps(prom), "prometheus.yml does not load alerts.yml")

# ---- Kubernetes ---------------------------------------------------------------------
k8s_files = sorted(glob.glob(os.path.join(DEPLOY, "k8s", "**", "*.y*ml"), recursive=True))
check(k8s_files, "no manifests in deploy/k8s")
objects = []
for f in k8s_files:
    for doc in load_all(f):  # every file must parse
        if isinstance(doc, dict) and "kind" in doc:
            objects.append((os.path.relpath(f, DEPLOY), doc))
by_kind = {}
for f, o in objects:
    by_kind.setdefault(o["kind"], []).append((f, o))

(kust,) = load_all(os.path.join(DEPLOY, "k8s", "kustomization.yaml"))
for r in kust.get("resources", []):
    check(os.path.exists(os.path.join(DEPLOY, "k8s", r)), "kustomization.yaml: %s is missing" % r)

deployments = [o for f, o in by_kind.get("Deployment", [])]
check(len(deployments) == 1, "k8s: expected one Deployment, found %d" % len(deployments))
dep = deployments[0]
pod = dep["spec"]["template"]
pod_labels = pod["metadata"].get("labels", {})
check(all(pod_labels.get(k) == v for k, v in dep["spec"]["selector"]["matchLabels"].items()),
      "Deployment: selector does not match the pod labels")
(container,) = [c for c in pod["spec"]["containers"] if c["name"] == "lane-server"]
check(container.get("image") == compose_image,
      "image mismatch: k8s %s, compose %s" % (container.get("image"), compose_image))
k8s_flags = flags_of(container.get("args"))
check_server_flags("Deployment args", k8s_flags)
k_grpc = port_of(k8s_flags.get("address", "0.0.0.0:%d" % DEFAULT_GRPC_PORT))
k_metrics = port_of(k8s_flags.get("metrics_address", "0.0.0.0:%d" % DEFAULT_METRICS_PORT))
check(k_grpc == DEFAULT_GRPC_PORT, "Deployment: --address port %s" % k_grpc)
check(k_metrics == DEFAULT_METRICS_PORT, "Deployment: --metrics_address port %s" % k_metrics)
ports = {p["name"]: p["containerPort"] for p in container.get("ports", [])}
check(ports.get("grpc") == k_grpc, "Deployment: containerPort grpc %s != --address port %s"
      % (ports.get("grpc"), k_grpc))
check(ports.get("metrics") == k_metrics, "Deployment: containerPort metrics %s != metrics port %s"
      % (ports.get("metrics"), k_metrics))
for probe_name in ("readinessProbe", "livenessProbe", "startupProbe"):
    probe = container.get(probe_name)
    if probe_name == "startupProbe" and probe is None:
        continue
    check(probe is not None and "grpc" in probe, "Deployment: %s is not a gRPC probe" % probe_name)
    if probe and "grpc" in probe:
        check(probe["grpc"].get("port") == k_grpc, "Deployment: %s port %s is not the gRPC port %s"
              % (probe_name, probe["grpc"].get("port"), k_grpc))
        check(probe["grpc"].get("service", "") == "",
              "Deployment: %s should check the whole server (service \"\")" % probe_name)
k_deadline = seconds(k8s_flags.get("shutdown_deadline", "%gs" % DEFAULT_DEADLINE))
prestop = container.get("lifecycle", {}).get("preStop", {})
prestop_s = 0.0
if "exec" in prestop and "sleep" in str(prestop["exec"].get("command", [""])[0]):
    prestop_s = float(prestop["exec"]["command"][-1])
elif "sleep" in prestop:
    prestop_s = float(prestop["sleep"].get("seconds", 0))
grace = pod["spec"].get("terminationGracePeriodSeconds", 30)
# + 2 s: stopping the metrics endpoint takes ~1.5 s after the deadline.
check(grace > prestop_s + k_deadline + 2,
      "Deployment: terminationGracePeriodSeconds %s <= preStop %g s + drain deadline %g s + 2 s"
      % (grace, prestop_s, k_deadline))
res = container.get("resources", {})
check("cpu" in res.get("requests", {}) and "memory" in res.get("requests", {}) and
      "cpu" in res.get("limits", {}) and "memory" in res.get("limits", {}),
      "Deployment: requests and limits for cpu and memory")
ann = pod["metadata"].get("annotations", {})
check(ann.get("prometheus.io/scrape") == "true", "Deployment: prometheus.io/scrape")
check(ann.get("prometheus.io/port") == str(k_metrics),
      "Deployment: prometheus.io/port %s is not the metrics port %s"
      % (ann.get("prometheus.io/port"), k_metrics))
check(ann.get("prometheus.io/path", "/metrics") == "/metrics", "Deployment: prometheus.io/path")
sc = pod["spec"].get("securityContext", {})
check(sc.get("runAsNonRoot") is True and sc.get("runAsUser", 0) != 0,
      "Deployment: not runAsNonRoot with a non-zero uid")
uid = re.search(r"^USER\s+(\d+)", dockerfile, re.M)
check(uid and str(sc.get("runAsUser")) == uid.group(1),
      "Deployment runAsUser %s != Dockerfile USER" % sc.get("runAsUser"))
# --workers=$(VAR) must name a defined env var.
for var in re.findall(r"\$\(([A-Z_]+)\)", " ".join(container.get("args", []))):
    check(any(e["name"] == var for e in container.get("env", [])),
          "Deployment: args use $(%s), which is not in env" % var)
# The default config: a mounted ConfigMap, passed as --default_config.
mounts = {m["name"]: m["mountPath"] for m in container.get("volumeMounts", [])}
volumes = {v["name"]: v for v in pod["spec"].get("volumes", [])}
default_config = k8s_flags.get("default_config", "")
config_maps = {o["metadata"]["name"]: o for f, o in by_kind.get("ConfigMap", [])}
found = False
for vname, path in mounts.items():
    v = volumes.get(vname, {})
    if "configMap" in v and default_config.startswith(path.rstrip("/") + "/"):
        cm = config_maps.get(v["configMap"]["name"])
        key = default_config[len(path.rstrip("/")) + 1:]
        found = check(cm is not None and key in cm.get("data", {}),
                      "ConfigMap %s has no key %s" % (v["configMap"]["name"], key))
        if found:
            shipped = json.loads(read("configs/synthetic.json"))
            check(json.loads(cm["data"][key]) == shipped,
                  "ConfigMap %s/%s differs from configs/synthetic.json" % (cm["metadata"]["name"], key))
check(found, "Deployment: --default_config=%s is not in a mounted ConfigMap" % default_config)

services_k8s = [o for f, o in by_kind.get("Service", [])]
headless = [s for s in services_k8s if s["spec"].get("clusterIP") == "None"]
check(headless, "k8s: no headless Service (clusterIP: None)")
for s in headless:
    check(all(pod_labels.get(k) == v for k, v in s["spec"]["selector"].items()),
          "Service %s: selector does not match the pods" % s["metadata"]["name"])
    sports = {p["name"]: p for p in s["spec"]["ports"]}
    g = sports.get("grpc", {})
    check(g.get("port") == k_grpc and g.get("targetPort") in ("grpc", k_grpc),
          "Service %s: grpc port %s -> %s" % (s["metadata"]["name"], g.get("port"), g.get("targetPort")))

monitors = [o for f, o in by_kind.get("ServiceMonitor", [])]
check(monitors, "k8s: no ServiceMonitor for the Prometheus Operator")
for mon in monitors:
    sel = mon["spec"]["selector"]["matchLabels"]
    matched = [s for s in services_k8s if all(s["metadata"].get("labels", {}).get(k) == v
                                              for k, v in sel.items())]
    check(matched, "ServiceMonitor %s selects no Service" % mon["metadata"]["name"])
    for s in matched:
        names = {p["name"] for p in s["spec"]["ports"]}
        for e in mon["spec"]["endpoints"]:
            check(e.get("port") in names and e.get("path", "/metrics") == "/metrics",
                  "ServiceMonitor %s: endpoint %s is not the Service's metrics port"
                  % (mon["metadata"]["name"], e))

dep_name = dep["metadata"]["name"]
hpas = [o for f, o in by_kind.get("HorizontalPodAutoscaler", [])]
check(any(any(m.get("type") == "Resource" and m["resource"]["name"] == "cpu"
              for m in h["spec"].get("metrics", [])) for h in hpas), "k8s: no HPA on CPU")
check(any(any(m.get("type") == "Pods" and m["pods"]["metric"]["name"] == "lanesvc_inflight_frames"
              for m in h["spec"].get("metrics", [])) for h in hpas),
      "k8s: no HPA variant on lanesvc_inflight_frames")
for h in hpas:
    ref = h["spec"]["scaleTargetRef"]
    check(ref["kind"] == "Deployment" and ref["name"] == dep_name,
          "HPA %s does not target the Deployment" % h["metadata"]["name"])
    check(h["spec"]["minReplicas"] >= 2, "HPA %s: minReplicas < 2 leaves no pod during a drain"
          % h["metadata"]["name"])
    check("cpu" in res.get("requests", {}), "HPA on CPU utilisation needs a CPU request")
pdbs = [o for f, o in by_kind.get("PodDisruptionBudget", [])]
check(pdbs, "k8s: no PodDisruptionBudget")
for p in pdbs:
    check(all(pod_labels.get(k) == v for k, v in p["spec"]["selector"]["matchLabels"].items()),
          "PDB %s: selector does not match the pods" % p["metadata"]["name"])
# prometheus-adapter rule for the custom-metric HPA.
adapter = [doc for f in k8s_files if "adapter" in os.path.basename(f) for doc in load_all(f)]
check(any("lanesvc_inflight_frames" in json.dumps(d) for d in adapter),
      "k8s: no prometheus-adapter rule for lanesvc_inflight_frames")

# ---- the back-fill Job (deploy/k8s/backfill, docs/backfill.md) -----------------------
backfill_dir = os.path.join(DEPLOY, "k8s", "backfill")
(bkust,) = load_all(os.path.join(backfill_dir, "kustomization.yaml"))
for r in bkust.get("resources", []):
    check(os.path.exists(os.path.join(backfill_dir, r)), "backfill kustomization: %s is missing" % r)
jobs = [o for f, o in by_kind.get("Job", []) if o["metadata"]["name"] == "lane-backfill"]
check(len(jobs) == 1, "k8s: expected the Job lane-backfill")
if jobs:
    job = jobs[0]["spec"]
    check(job.get("completionMode") == "Indexed", "lane-backfill: not an Indexed Job")
    check(job.get("completions") == job.get("parallelism"),
          "lane-backfill: completions != parallelism")
    check(isinstance(job.get("backoffLimit"), int), "lane-backfill: no backoffLimit")
    (bc,) = job["template"]["spec"]["containers"]
    check(bc.get("image") == compose_image, "lane-backfill: image %s, compose %s"
          % (bc.get("image"), compose_image))
    check(bc.get("command") == ["lane", "backfill"], "lane-backfill: command is not lane backfill")
    bflags = flags_of(bc.get("args"))
    shard = bflags.get("shard", "")
    check(shard == "$(JOB_COMPLETION_INDEX)/%s" % job.get("completions"),
          "lane-backfill: --shard %s does not map the completion index onto %s shards"
          % (shard, job.get("completions")))
    env_names = {e["name"]: e for e in bc.get("env", [])}
    check("job-completion-index" in json.dumps(env_names.get("JOB_COMPLETION_INDEX", {})),
          "lane-backfill: JOB_COMPLETION_INDEX does not come from the completion index")
    check(all(k in bflags for k in ("manifest", "output-dir")),
          "lane-backfill: --manifest and --output-dir are required")
    check(bc.get("resources", {}).get("requests", {}).get("cpu") == bflags.get("jobs"),
          "lane-backfill: the CPU request should equal --jobs")
    mounts = {m["mountPath"] for m in bc.get("volumeMounts", [])}
    check(any(bflags.get("manifest", "").startswith(m + "/") for m in mounts),
          "lane-backfill: the manifest is not on a mounted volume")
    claims = {v["persistentVolumeClaim"]["claimName"] for v in job["template"]["spec"]["volumes"]
              if "persistentVolumeClaim" in v}
    pvcs = {o["metadata"]["name"] for f, o in by_kind.get("PersistentVolumeClaim", [])}
    check(claims and claims <= pvcs, "lane-backfill: claims %s, PVCs %s" % (claims, pvcs))
    # `kubectl kustomize` renders it, where kubectl is installed.
    import shutil
    import subprocess
    if shutil.which("kubectl"):
        rendered = subprocess.run(["kubectl", "kustomize", backfill_dir], capture_output=True,
                                  text=True)
        check(rendered.returncode == 0 and "kind: Job" in rendered.stdout,
              "kubectl kustomize deploy/k8s/backfill: %s" % rendered.stderr.strip())

print("deploy manifests: %d checks over compose.yaml, %d Kubernetes files (%d objects), "
      "Prometheus, Grafana (%d queries) and the Dockerfile" % (
          checks, len(k8s_files), len(objects), len(exprs)))
if failures:
    for f in failures:
        print("FAIL: " + f)
    sys.exit(1)
print("PASS")

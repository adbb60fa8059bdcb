#!/usr/bin/env python3
"""lane-server --log_format=json: every stderr line is one JSON object with
ts, level, logger and msg (gRPC's own log lines included, as logger
"grpc"); start-up, a drain on SIGTERM and the stop are
events with their fields; a start-up failure is an error event; an unknown
format is a usage error (exit 2). The default text format is unchanged.
Flags are taken with dashes as well as underscores.

Usage: log_format_test.py LANE_SERVER SOURCE_DIR
"""
import json
import re
import signal
import socket
import subprocess
import sys

SERVER, SRC = sys.argv[1:3]
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL:", message, flush=True)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def events(text):
    out = []
    for line in text.splitlines():
        try:
            event = json.loads(line)
        except ValueError:
            check(False, "not a JSON line: %r" % line)
            continue
        check(isinstance(event, dict) and {"ts", "level", "logger", "msg"} <= set(event),
              "missing fields: %r" % line)
        check(re.match(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z$", event.get("ts", "")) is not None,
              "ts is not UTC ISO 8601: %r" % event.get("ts"))
        out.append(event)
    return out


port = free_port()
# Dashes or underscores: the server takes both spellings of its flags.
args = [SERVER, "--address=127.0.0.1:%d" % port, "--metrics-address=127.0.0.1:0",
        "--default_config=%s/configs/synthetic.json" % SRC, "--log-format", "json"]
proc = subprocess.Popen(args, stderr=subprocess.PIPE, text=True)
first = proc.stderr.readline()
started = events(first)
check(len(started) == 1 and started[0]["msg"] == "started" and started[0]["level"] == "info",
      "first event: %r" % first)
if started:
    e = started[0]
    check(e.get("grpc_port") == port and e.get("metrics_port", 0) > 0 and
          e.get("default_session") == "default" and e.get("tls") == "off" and
          e.get("logger") == "lane-server" and e.get("version"),
          "started fields: %r" % e)

    # A second server on the same port: an error event, exit 1.
    busy = subprocess.run(args, stderr=subprocess.PIPE, text=True, timeout=60)
    # gRPC's own error comes first, as a JSON event of logger "grpc".
    errors = [e for e in events(busy.stderr) if e["logger"] == "lane-server"]
    check(busy.returncode == 1 and len(errors) == 1 and errors[0]["level"] == "error" and
          "in use" in errors[0]["msg"] and errors[0].get("code") == "UNAVAILABLE",
          "busy port: exit %d, %r" % (busy.returncode, busy.stderr))

proc.send_signal(signal.SIGTERM)
rest = proc.stderr.read()
code = proc.wait(timeout=60)
later = events(rest)
check(code == 0, "exit %d after SIGTERM" % code)
check([e["msg"] for e in later] == ["draining", "stopped"], "events after SIGTERM: %r" % rest)
check(later and later[0].get("signal") == signal.SIGTERM, "draining event: %r" % rest)

bad = subprocess.run([SERVER, "--log_format=yaml"], stderr=subprocess.PIPE, text=True, timeout=30)
check(bad.returncode == 2 and "--log_format must be text or json" in bad.stderr,
      "--log_format=yaml: exit %d, %r" % (bad.returncode, bad.stderr))

# The default stays text for people.
port = free_port()
proc = subprocess.Popen([SERVER, "--address=127.0.0.1:%d" % port, "--metrics_address="],
                        stderr=subprocess.PIPE, text=True)
first = proc.stderr.readline()
proc.send_signal(signal.SIGTERM)
proc.stderr.read()
proc.wait(timeout=60)
check(first.startswith("lane-server ") and ": gRPC on port %d" % port in first,
      "text start line: %r" % first)

if failures:
    print("%d failure(s)" % len(failures))
    sys.exit(1)
print("lane-server --log_format=json: PASS")

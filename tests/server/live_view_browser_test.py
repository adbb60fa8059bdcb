#!/usr/bin/env python3
"""The live view in a real browser (issue 50): headless Chromium through
Selenium against a real lane-server streamed to by a real lane-client.

  1. Rendered synthetic frames (`lane render`), a server with --live_view and
     a Bearer token, and without the token every page answers 401.
  2. Camera ids that would be script are refused by CreateSession; one that
     looks like a path (`../../etc/passwd`) is a session like any other.
  3. The browser opens the URL `lane-client view` prints (the login form),
     logs in with the token, sees the cameras on `/`, opens
     `/cameras/cam0` and watches while `lane-client stream` sends the frames.
  4. The frame picture decodes at the stream's size, the top view too, and
     the lanes table is the last response the client wrote (--output).
  5. Ids and markup in URLs do not run: no alert, no injected element.
  6. No console error on the way; screenshots of both pages are saved in
     OUTDIR (live_view_camera.png, live_view_index.png).

usage: live_view_browser_test.py LANE_SERVER LANE_CLIENT LANE SOURCE_DIR OUTDIR
Exits 77 (skipped) when Chromium, chromedriver or Selenium is missing.
"""
import http.client
import json
import os
import re
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import time

SKIP = 77


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def http_status(port, path, headers=None):
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    connection.request("GET", path, headers=headers or {})
    response = connection.getresponse()
    body = response.read()
    connection.close()
    return response.status, body


def wait_for(what, condition, timeout_s=30.0, interval_s=0.1):
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            fail("timed out waiting for " + what)
        time.sleep(interval_s)


def start_server(server, source_dir, work, token_file):
    log = open(os.path.join(work, "server.err"), "w")
    process = subprocess.Popen(
        [server, "--address=127.0.0.1:0", "--metrics_address=127.0.0.1:0", "--live_view",
         "--workers=1", "--auth_tokens_file=" + token_file,
         "--default_config=" + os.path.join(source_dir, "configs/synthetic.json"),
         "--default_camera_id=cam0"],
        stdout=subprocess.DEVNULL, stderr=log)
    path = os.path.join(work, "server.err")

    def ports():
        if process.poll() is not None:
            fail("lane-server exited: " + open(path).read())
        match = re.search(r"gRPC on port (\d+), metrics on port (\d+)", open(path).read())
        return (int(match.group(1)), int(match.group(2))) if match else None

    grpc_port, http_port = wait_for("lane-server's ports", ports, 30)
    return process, grpc_port, http_port


def make_browser(work):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium")
    for flag in ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage",
                 "--window-size=1400,1300", "--user-data-dir=" + os.path.join(work, "profile")]:
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)


def console_errors(driver, allowed=()):
    errors = []
    for entry in driver.get_log("browser"):
        if entry.get("level") != "SEVERE":
            continue
        if any(a in entry.get("message", "") for a in allowed):
            continue
        errors.append(entry["message"])
    return errors


def no_alert(driver):
    from selenium.common.exceptions import NoAlertPresentException
    try:
        text = driver.switch_to.alert.text
    except NoAlertPresentException:
        return True
    fail("an alert ran: " + text)
    return False


class Run:
    """What the steps share: the programs, the server's ports, the token."""

    def __init__(self, client, source_dir, work, token, grpc_port, http_port):
        self.client, self.work, self.token = client, work, token
        self.config = os.path.join(source_dir, "configs/synthetic.json")
        self.target = "127.0.0.1:%d" % grpc_port
        self.http_port = http_port
        self.base = "http://127.0.0.1:%d" % http_port
        self.env = dict(os.environ, LANE_TOKEN=token)

    def view_url(self, *camera):
        """The URL `lane-client view` prints (with a token: the login page)."""
        run = subprocess.run([self.client, "view", "--target", self.target, "--no-open"] +
                             (["--camera", camera[0]] if camera else []),
                             env=self.env, capture_output=True, text=True)
        if run.returncode != 0:
            fail("lane-client view failed: " + run.stderr)
        return run.stdout.strip()


def check_unauthorized(run):
    """1. Without the token: 401 everywhere, and the token is never echoed."""
    for path in ["/", "/cameras/cam0", "/cameras/cam0/frame.jpg", "/api/sessions",
                 "/api/cameras/cam0"]:
        status, body = http_status(run.http_port, path)
        if status != 401:
            fail("%s without a token answered %d, not 401" % (path, status))
        status, _ = http_status(run.http_port, path, {"Authorization": "Bearer wrong"})
        if status != 401:
            fail("%s with a wrong token answered %d, not 401" % (path, status))
    print("ok: without the token the pages answer 401")


def check_hostile_ids(run):
    """2. Hostile camera ids."""
    for hostile in ['<script>alert(1)</script>', '"><img src=x onerror=alert(1)>']:
        created = subprocess.run([run.client, "session", "create", "--target", run.target,
                                  "--camera", hostile, "--config", run.config], env=run.env,
                                 capture_output=True, text=True)
        # lane-client refuses such an id before sending it (exit 2); the
        # server's own refusal is HostileInputTest's (server_test).
        said = created.stderr + created.stdout
        if created.returncode == 0 or ("INVALID_ARGUMENT" not in said
                                       and "character outside" not in said):
            fail("camera id %r was not refused: %s" % (hostile, created.stderr))
    subprocess.run([run.client, "session", "create", "--target", run.target, "--camera",
                    "../../etc/passwd", "--config", run.config], env=run.env, check=True,
                   capture_output=True)
    print("ok: script-like camera ids are refused")


def log_in_and_watch(run, driver):
    """3. Log in, see the cameras, open cam0's page."""
    if run.view_url("cam0") != run.base + "/login?next=%2Fcameras%2Fcam0":
        fail("lane-client view printed " + run.view_url("cam0"))
    index_url = run.view_url()
    if index_url != run.base + "/login?next=%2F":
        fail("lane-client view printed " + index_url)
    driver.set_page_load_timeout(20)
    driver.get(index_url)
    driver.find_element("name", "token").send_keys(run.token)
    driver.find_element("css selector", "form button[type=submit]").click()
    wait_for("the login", lambda: driver.current_url == run.base + "/")
    if run.token in driver.current_url:
        fail("the token stayed in the URL")
    wait_for("cam0 on /", lambda: driver.execute_script(
        "return document.querySelector('tr[data-camera=\"cam0\"]') !== null"))
    wait_for("../../etc/passwd on /", lambda: driver.execute_script(
        "const r = document.querySelector('tr[data-camera=\"../../etc/passwd\"] a');"
        "return r !== null && r.textContent === '../../etc/passwd' && "
        "r.getAttribute('href').startsWith('/cameras/..%2F..%2Fetc%2Fpasswd?')"))
    driver.find_element("css selector", "tr[data-camera=\"cam0\"] a").click()
    wait_for("the camera page", lambda: driver.execute_script(
        "return document.body.dataset.page === 'camera' && "
        "document.getElementById('camera').textContent === 'cam0'"))


def stream_frames(run, frames):
    """3. (cont.) `lane-client stream` sends the frames; the last response."""
    results = os.path.join(run.work, "results.jsonl")
    stream = subprocess.run(
        [run.client, "stream", "--target", run.target, "--camera", "cam0", "--fps", "20",
         "--output", results, "--no-progress", "--quiet", frames],
        env=run.env, capture_output=True, text=True, timeout=120)
    if stream.returncode != 0:
        fail("lane-client stream failed: " + stream.stderr)
    responses = [json.loads(line) for line in open(results) if line.strip()]
    if len(responses) != 60 or any(r["status"] != "OK" for r in responses):
        fail("the stream's responses are not 60 OK ones")
    last = responses[-1]
    print("ok: streamed 60 frames, last frame_id %d with %d lanes"
          % (last["frame_id"], len(last["lanes"])))
    return last


def check_table_and_pictures(run, driver, last, outdir):
    """4. The pictures and the lanes table; 6. screenshots, no console error."""
    wait_for("the table of the last response", lambda: driver.execute_script(
        "return document.getElementById('lanes-caption').textContent"
    ) == "Lanes of the last response (frame %d)." % last["frame_id"])
    rows = driver.execute_script(
        "return Array.from(document.querySelectorAll('#lanes-body tr')).map(r => "
        "[Number(r.dataset.laneId), Number(r.dataset.score), Number(r.dataset.offset), "
        "r.children[3].textContent])")
    if len(rows) != len(last["lanes"]) or not rows:
        fail("the table has %d lanes, the last response %d" % (len(rows), len(last["lanes"])))
    for row, lane_json in zip(rows, last["lanes"]):
        ground = lane_json["ground"]
        near_x = ground[0][0] if ground[0][1] <= ground[3][1] else ground[3][0]
        if row[0] != lane_json["id"] or abs(row[1] - lane_json["score"]) > 1e-3 or \
                abs(row[2] - near_x) > 1e-3 or abs(float(row[3]) - lane_json["score"]) > 6e-4:
            fail("table row %r differs from the response's lane %r" % (row, lane_json))
    print("ok: the lanes table is the last response's (%d lanes)" % len(rows))
    size = wait_for("the frame picture", lambda: driver.execute_script(
        "const i = document.getElementById('frame'); const t = document.getElementById('top');"
        "return i.complete && i.naturalWidth > 0 && t.complete && t.naturalWidth > 0 ? "
        "[i.naturalWidth, i.naturalHeight, t.naturalWidth] : null"))
    if size[0] != 640 or size[1] != 480:
        fail("the frame picture is %dx%d, the stream's frames 640x480" % (size[0], size[1]))
    print("ok: the frame picture decodes at %dx%d, the top view is %d wide"
          % (size[0], size[1], size[2]))
    time.sleep(1.2)  # one more refresh of the chart and state
    os.makedirs(outdir, exist_ok=True)
    driver.save_screenshot(os.path.join(outdir, "live_view_camera.png"))
    driver.get(run.base + "/")
    wait_for("the index's rates", lambda: driver.execute_script(
        "const r = document.querySelector('tr[data-camera=\"cam0\"]');"
        "return r !== null && r.children[4].textContent !== '\u2013'"))
    driver.save_screenshot(os.path.join(outdir, "live_view_index.png"))
    errors = console_errors(driver)
    if errors:
        fail("console errors: " + "; ".join(errors))
    no_alert(driver)
    print("ok: no console error; screenshots in " + outdir)


def check_hostile_urls(run, driver):
    """5. Markup in URLs and ids: shown as text, never run."""
    driver.get(run.base + "/cameras/..%2F..%2Fetc%2Fpasswd")
    wait_for("the path-like camera's page", lambda: driver.execute_script(
        "return document.getElementById('camera') && "
        "document.getElementById('camera').textContent === '../../etc/passwd'"))
    if "root:" in driver.page_source:
        fail("a file's content reached the page")
    for path in ["/cameras/%3Cscript%3Ealert(1)%3C%2Fscript%3E",
                 "/cameras/%22%3E%3Cimg%20src%3Dx%20onerror%3D%22document.title%3D'pwned'%22%3E",
                 "/cameras/x?viewer=%22%3E%3Cscript%3Ealert(2)%3C/script%3E",
                 "/../../etc/passwd"]:
        driver.get(run.base + path)
        time.sleep(0.3)
        no_alert(driver)
        injected = driver.execute_script(
            "return document.title === 'pwned' || document.querySelectorAll('img[src=x]')."
            "length > 0 || Array.from(document.scripts).some(s => !s.src.endsWith('/live.js'))")
        if injected:
            fail("markup from " + path + " reached the page")
        if "root:" in driver.page_source:
            fail("a file's content reached the page")
    errors = console_errors(driver, allowed=("404 (Not Found)",))
    if errors:
        fail("console errors on the hostile URLs: " + "; ".join(errors))
    print("ok: hostile ids and URLs are shown as text or refused; no script ran")


def main():
    if len(sys.argv) != 6:
        print(__doc__, file=sys.stderr)
        return 2
    server, client, lane, source_dir, outdir = sys.argv[1:]
    missing = [p for p in ("chromium", "chromedriver") if shutil.which(p) is None]
    try:
        import selenium  # noqa: F401
    except ImportError:
        missing.append("python3-selenium")
    if missing:
        print("SKIP: not installed: " + ", ".join(missing) + " (scripts/install-deps.sh)")
        return SKIP
    started = time.monotonic()
    work = tempfile.mkdtemp(prefix="live_view_browser_")
    process = None
    driver = None
    try:
        frames = os.path.join(work, "frames")
        subprocess.run([lane, "render", "--config", os.path.join(source_dir, "configs/synthetic.json"),
                        "--count", "60", "--seed", "1", "--format", "jpg", "--output", frames],
                       check=True, stdout=subprocess.DEVNULL)
        token = "live-" + secrets.token_hex(16)
        token_file = os.path.join(work, "token")
        with open(token_file, "w") as f:
            f.write(token + "\n")
        os.chmod(token_file, 0o600)
        process, grpc_port, http_port = start_server(server, source_dir, work, token_file)
        run = Run(client, source_dir, work, token, grpc_port, http_port)
        check_unauthorized(run)
        check_hostile_ids(run)
        driver = make_browser(work)
        log_in_and_watch(run, driver)
        last = stream_frames(run, frames)
        check_table_and_pictures(run, driver, last, outdir)
        check_hostile_urls(run, driver)
        print("live view browser test passed in %.1f s" % (time.monotonic() - started))
        return 0
    finally:
        if driver is not None:
            driver.quit()
        if process is not None:
            process.send_signal(signal.SIGTERM)
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())

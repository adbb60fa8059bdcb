#!/usr/bin/env bash
# `lane backfill` end to end (issue 38), on rendered drives (and on the two
# real clips of ../shared/data, read in place, when they are there):
#   1. one unsharded run: the good recordings done, a corrupt one and a
#      missing one reported as failed (exit 1), the others unaffected;
#   2. 4 shards (scripts/backfill-local.sh): each recording in exactly one
#      shard, and the union of the outputs equals the unsharded run's, byte
#      for byte once the timings are dropped;
#   3. a shard killed (SIGKILL) mid-recording and run again: the finished
#      recordings are not recomputed (their modification times), none is
#      lost or duplicated, and the outputs still equal the unsharded run's.
#
# usage: backfill_test.sh LANE SOURCE_DIR
set -euo pipefail
lane=$1
src=$2
dir=$(mktemp -d)
bg=
cleanup() {
  [ -z "$bg" ] || kill -9 "$bg" 2>/dev/null || true
  rm -rf "$dir"
}
trap cleanup EXIT
fail() {
  echo "FAIL: $*" >&2
  exit 1
}

# Recordings: 4 drives of the synthetic camera (one as a video when ffmpeg is
# there), 1 of the Caltech camera (its own config), a folder of one corrupt
# frame, and a path that does not exist.
for i in 1 2 3 4; do
  "$lane" render --config "$src/configs/synthetic.json" --sequence --count 40 --seed "$i" \
    --format jpg --output "$dir/drive$i" >/dev/null 2>&1
done
"$lane" render --config "$src/configs/caltech.json" --sequence --count 30 --seed 9 \
  --format jpg --output "$dir/caltech" >/dev/null 2>&1
mkdir "$dir/corrupt"
printf '\xff\xd8\xff not a JPEG' >"$dir/corrupt/000000.jpg"
drive4=drive4
if command -v ffmpeg >/dev/null; then
  ffmpeg -loglevel error -framerate 15 -i "$dir/drive4/%06d.jpg" -c:v mjpeg -q:v 2 \
    "$dir/drive4.avi" && drive4=drive4.avi
fi
cat >"$dir/manifest.jsonl" <<JSON
{"recording": "drive1", "config": "$src/configs/synthetic.json", "output": "cam1-drive1"}
{"recording": "drive2", "config": "$src/configs/synthetic.json", "output": "cam1-drive2"}

{"recording": "drive3", "config": "$src/configs/synthetic.json", "output": "cam2-drive3"}
{"recording": "$drive4", "config": "$src/configs/synthetic.json", "output": "cam2-drive4"}
{"recording": "caltech", "config": "$src/configs/caltech.json", "output": "caltech-cordova"}
{"recording": "corrupt", "config": "$src/configs/synthetic.json", "output": "corrupt"}
{"recording": "missing", "config": "$src/configs/synthetic.json", "output": "missing"}
JSON
good="cam1-drive1 cam1-drive2 cam2-drive3 cam2-drive4 caltech-cordova"
# The real clips too, when ../shared/data is there (never copied: read in place).
data=$(cd "$src/.." && pwd)/shared/data
real=0
if [ -d "$data/culane-driver161-a" ] && [ -d "$data/caltech-cordova1" ]; then
  cat >>"$dir/manifest.jsonl" <<JSON
{"recording": "$data/culane-driver161-a", "config": "$src/configs/culane-driver161.json", "output": "culane-driver161-a"}
{"recording": "$data/caltech-cordova1", "config": "$src/configs/caltech.json", "output": "caltech-cordova1"}
JSON
  good="$good culane-driver161-a caltech-cordova1"
  real=2
else
  echo "note: ../shared/data is absent: rendered drives only"
fi

# stripped DIR: each output without its timings and its trailer (whose
# SHA-256 covers the timings), into DIR.stripped/.
stripped() {
  mkdir -p "$1.stripped"
  for f in "$1"/*.jsonl; do
    python3 -c '
import json, sys
lines = open(sys.argv[1]).read().splitlines()
assert "trailer" in json.loads(lines[-1]), sys.argv[1] + ": no trailer"
for line in lines[:-1]:
    j = json.loads(line)
    j.pop("timing_ms", None)
    print(json.dumps(j, sort_keys=True))' "$f" >"$1.stripped/$(basename "$f")"
  done
}

# 1. Unsharded.
status=0
"$lane" backfill --manifest "$dir/manifest.jsonl" --output-dir "$dir/all" --quiet \
  2>"$dir/all.err" || status=$?
[ "$status" -eq 1 ] || { cat "$dir/all.err" >&2; fail "unsharded run: exit $status, expected 1"; }
python3 - "$dir/all/summary-shard-0-of-1.json" "$real" <<'PY' || fail "unsharded summary"
import json, sys
s = json.load(open(sys.argv[1]))
real = int(sys.argv[2])
by = {r["output"]: r for r in s["recordings"]}
assert s["done"] == 5 + real and s["failed"] == 2 and s["skipped"] == 0, s
if real:
    assert by["culane-driver161-a"]["frames"] == 60 and by["caltech-cordova1"]["frames"] == 250, by
assert by["corrupt"]["status"] == "failed" and by["missing"]["status"] == "failed", by
for name in ("cam1-drive1", "cam1-drive2", "cam2-drive3", "cam2-drive4", "caltech-cordova"):
    r = by[name]
    assert r["status"] == "done" and r["failed_frames"] == 0, r
    assert r["frames"] in (30, 40), r
    assert 1.5 <= r["lanes_per_frame"] <= 6, r
print(f"ok: unsharded: {s['frames']} frames, {5 + real} recordings done, 2 failed and reported")
PY
for name in $good; do
  [ -f "$dir/all/$name.jsonl" ] || fail "no output for $name"
  n=$(grep -c '"lanes"' "$dir/all/$name.jsonl" || true)
  ids=$(grep -c '"id":' "$dir/all/$name.jsonl" || true)
  [ "$n" -ge 30 ] && [ "$ids" -ge 15 ] || fail "$name: $n frames, $ids with tracked lane ids"
done
[ ! -e "$dir/all/corrupt.jsonl" ] && [ ! -e "$dir/all/missing.jsonl" ] || fail "output of a failed recording"
[ -z "$(find "$dir/all" -maxdepth 1 -name '.*.partial*' -o -name '.*.lock')" ] ||
  fail "partial or lock files left"
stripped "$dir/all"

# 2. Four shards.
status=0
"$src/scripts/backfill-local.sh" "$dir/manifest.jsonl" "$dir/four" 4 "$lane" >"$dir/four.out" \
  2>&1 || status=$?
[ "$status" -eq 1 ] || { cat "$dir/four.out" >&2; fail "4 shards: exit $status, expected 1"; }
python3 - "$dir/four" "$real" <<'PY' || fail "4 shards' summaries"
import collections, json, sys
seen = collections.Counter()
for i in range(4):
    s = json.load(open(f"{sys.argv[1]}/summary-shard-{i}-of-4.json"))
    seen.update(r["output"] for r in s["recordings"])
n = 7 + int(sys.argv[2])
assert len(seen) == n and set(seen.values()) == {1}, seen
print(f"ok: 4 shards: each of the {n} recordings in exactly one shard")
PY
stripped "$dir/four"
diff -r "$dir/all.stripped" "$dir/four.stripped" >/dev/null ||
  fail "the 4 shards' outputs differ from the unsharded run's"
echo "ok: the union of 4 shards equals the unsharded run (without timings)"

# 3. Killed and resumed. A long recording (a list file of 400 frames) second
# in the manifest, so that the kill lands in it.
for k in $(seq 1 10); do
  for f in "$dir"/drive1/*.jpg; do echo "drive1/$(basename "$f")"; done
done >"$dir/long.txt"
{ head -1 "$dir/manifest.jsonl"
  echo '{"recording": "long.txt", "config": "'"$src"'/configs/synthetic.json", "output": "long"}'
  tail -n +2 "$dir/manifest.jsonl"; } >"$dir/manifest-kill.jsonl"
count() { find "$dir/kill" -maxdepth 1 -name "$1" 2>/dev/null | wc -l; }
"$lane" backfill --manifest "$dir/manifest-kill.jsonl" --output-dir "$dir/kill" --jobs 1 --quiet \
  2>/dev/null &
bg=$!
for _ in $(seq 1 2000); do
  [ "$(count '*.jsonl')" -ge 1 ] && [ "$(count '.*.partial.*')" -ge 1 ] && break
  sleep 0.005
done
kill -9 "$bg" 2>/dev/null || true
wait "$bg" 2>/dev/null || true
bg=
finished=$(count '*.jsonl')
total=$((6 + real))
[ "$finished" -ge 1 ] && [ "$finished" -lt "$total" ] || fail "the kill came at a bad time: $finished finished"
[ "$(count '.*.partial.*')" -eq 1 ] || fail "no partial output at the kill"
(cd "$dir/kill" && stat -c '%n %Y.%y' ./*.jsonl) >"$dir/before.txt"
sleep 1.1
status=0
"$lane" backfill --manifest "$dir/manifest-kill.jsonl" --output-dir "$dir/kill" --quiet \
  2>/dev/null || status=$?
[ "$status" -eq 1 ] || fail "resumed run: exit $status"
while read -r name stamp; do
  [ "$(cd "$dir/kill" && stat -c '%Y.%y' "$name")" = "$stamp" ] || fail "$name was recomputed"
done <"$dir/before.txt"
python3 - "$dir/kill/summary-shard-0-of-1.json" "$finished" "$total" <<'PY' || fail "resumed summary"
import json, sys
s = json.load(open(sys.argv[1]))
assert s["skipped"] == int(sys.argv[2]) and s["done"] == int(sys.argv[3]) - int(sys.argv[2]), s
assert [r for r in s["recordings"] if r["output"] == "long"][0]["frames"] in (0, 400), s
# The killed run's partial file, removed by the run that claimed its recording.
assert sum(r.get("removed_partials", 0) for r in s["recordings"]) == 1, s
PY
[ "$(count '.*.partial*')" -eq 0 ] || fail "partial files left after the resumed run"
[ "$(count '.*.lock')" -eq 0 ] || fail "lock files left after the resumed run"
[ "$(grep -c '"frame"' "$dir/kill/long.jsonl")" -eq 400 ] || fail "long.jsonl is not 400 frames"
stripped "$dir/kill"
for name in $good; do
  cmp -s "$dir/all.stripped/$name.jsonl" "$dir/kill.stripped/$name.jsonl" ||
    fail "$name: the killed and resumed run's output differs from the unsharded run's"
done
echo "ok: killed after $finished recordings; resumed without recomputing them; same outputs"

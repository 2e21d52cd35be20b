#!/usr/bin/env bash
# Reads Speleo recordings as ROS 2 users do, without ROS installed:
#  1. a 60 s simulated mission recorded, described by `speleo info`, decoded
#     message by message by `mcap-ros2-support` and `rosbags`
#     (ci/ros2_check.py), and replayed identically;
#  2. a recorded mission stopped by a real SIGINT: it exits 130 with its
#     report, and the `mcap` package's indexed reader accepts the recording
#     (summary and chunk index written).
# The Python readers go into a virtual environment under the target folder
# (pinned versions, fetched from PyPI once).
#
#   SPELEO  the binary (default target/release/speleo)
set -euo pipefail
cd "$(dirname "$0")/.."

say() { echo "== ros2-check: $*"; }
die() { echo "ros2-check: $*" >&2; exit 1; }

target="${CARGO_TARGET_DIR:-target}"
speleo="${SPELEO:-$target/release/speleo}"
[ -x "$speleo" ] || die "no speleo binary at $speleo (cargo build --release, or set SPELEO)"

venv="$target/ros2-check-venv"
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c "import rosbags, mcap_ros2" 2>/dev/null; then
  say "installing rosbags, mcap and mcap-ros2-support into $venv"
  python3 -m venv "$venv" || die "python3 -m venv failed (Debian: apt-get install python3-venv)"
  "$venv/bin/pip" install --quiet --disable-pip-version-check \
    rosbags==0.11.9 mcap==1.6.0 mcap-ros2-support==0.6.0
fi
py="$venv/bin/python"

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

say "a 60 s recorded mission"
"$speleo" sim --duration 60 --record "$work/a.mcap" --report "$work/a.json" --no-progress >/dev/null
"$speleo" info "$work/a.mcap"
say "every message through mcap-ros2-support and rosbags"
"$py" ci/ros2_check.py "$work/a.mcap"
say "replay"
"$speleo" replay "$work/a.mcap" --report "$work/r.json" --no-progress | tail -n 3
grep -q '"identical": *true' "$work/r.json" || die "the replay is not identical"

say "Ctrl-C during a recorded mission"
"$speleo" sim --duration 600 --record "$work/c.mcap" --report "$work/c.json" --no-progress >/dev/null &
pid=$!
# Wait until the mission has written a chunk or two.
for _ in $(seq 1 100); do
  [ -s "$work/c.mcap" ] && [ "$(stat -c %s "$work/c.mcap")" -gt 4000000 ] && break
  sleep 0.2
done
kill -INT "$pid"
status=0
wait "$pid" || status=$?
[ "$status" = 130 ] || die "sim ended with $status after SIGINT, not 130"
[ -s "$work/c.json" ] || die "no report after SIGINT"
"$py" - "$work/c.mcap" <<'PY'
import sys
from mcap.reader import make_reader
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f)
    summary = reader.get_summary()
    assert summary is not None, "no summary"
    assert summary.chunk_indexes, "no chunk index"
    n = sum(1 for _ in reader.iter_messages())
    assert n == summary.statistics.message_count, (n, summary.statistics.message_count)
    print(f"interrupted recording: {n} messages in {len(summary.chunk_indexes)} indexed chunks")
PY
say "passed"

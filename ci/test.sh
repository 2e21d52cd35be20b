#!/usr/bin/env bash
# The project's test command (README.md): format check, clippy with warnings
# denied, every test of the workspace, the end-to-end exploration in release,
# the hardware-in-the-loop bench (twin and `run` in real time, 100 s),
# a recording read by the ROS 2 Python readers (rosbags, mcap-ros2-support)
# and stopped by a real SIGINT, a tiny campaign through a real one-node Slurm
# cluster, then each fuzz target for a bounded time (SPELEO_FUZZ_SECONDS,
# default 15; 0 skips). Needs a Rust toolchain with rustfmt and clippy and
# Python 3 with venv; everything else is fetched by cargo and pip.
set -euo pipefail
cd "$(dirname "$0")/.."
# A clean CI build need not keep incremental state, which only costs disk.
export CARGO_INCREMENTAL=0

if ! cargo fmt --version >/dev/null 2>&1; then
  rustup component add rustfmt
fi
if ! cargo clippy --version >/dev/null 2>&1; then
  rustup component add clippy
fi

echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --workspace --all-targets --locked -- -D warnings
echo "== the executive's core without std"
cargo check -p speleo-scheduler --no-default-features --locked
echo "== cargo test"
cargo test --workspace --locked
# The debug build is not used again; its space goes to the release and fuzz builds.
cargo clean --profile dev
echo "== the autonomous mission end to end (release: minutes, not the debug build's hour)"
cargo test --release -p speleo-tests --test exploration --locked -- --ignored
cargo build --release --locked -p speleo-cli
echo "== the hardware-in-the-loop bench: twin and flight binary in real time on the real wires"
cargo test --release -p speleo-cli --test hil --locked -- --ignored
echo "== recordings as ROS 2 tools read them"
bash ci/ros2-check.sh
echo "== a campaign on a one-node Slurm cluster (installs slurm-wlm and munge)"
bash ci/slurm-campaign.sh
echo "== fuzz targets"
bash ci/fuzz.sh

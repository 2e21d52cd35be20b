#!/usr/bin/env bash
# Run every fuzz target for a bounded time (SPELEO_FUZZ_SECONDS each, default
# 15; 0 skips). cargo-fuzz needs nightly features: RUSTC_BOOTSTRAP lets the
# stable toolchain build them. A crash fails the run and leaves the input in
# fuzz/artifacts/.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${SPELEO_FUZZ_SECONDS:-15}"
if [ "$seconds" = "0" ]; then
  echo "fuzzing skipped (SPELEO_FUZZ_SECONDS=0)"
  exit 0
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
  cargo install cargo-fuzz --locked --version 0.13.2
fi
export RUSTC_BOOTSTRAP=1
for target in $(cargo fuzz list --fuzz-dir fuzz); do
  echo "== fuzz $target (${seconds} s)"
  # New inputs go to fuzz/corpus (not kept); fuzz/seeds holds the kept
  # starting points (real files, and inputs that once crashed).
  mkdir -p "fuzz/corpus/$target"
  dirs=("fuzz/corpus/$target")
  if [ -d "fuzz/seeds/$target" ]; then
    dirs+=("fuzz/seeds/$target")
  fi
  cargo fuzz run --fuzz-dir fuzz "$target" "${dirs[@]}" -- -max_total_time="$seconds" -rss_limit_mb=2048 2>&1 \
    | grep -E "^(#[0-9]+ +DONE|Done|==[0-9]+==|thread|SUMMARY|panicked)" || true
  # grep hides libFuzzer's progress lines; the exit status is cargo fuzz's.
  test "${PIPESTATUS[0]}" -eq 0
done

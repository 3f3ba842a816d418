#!/usr/bin/env bash
# The repository stands alone: clones the committed HEAD into an empty temporary folder (nothing beside it) and runs
# `make demo` there as a newcomer would (set-up, build, the demo's episodes), then checks what it promises: the
# episodes' lines, at least one goal reached, the trajectories PNG and the bag. Prints the time of each step.
#   scripts/clean_clone_demo.sh [--keep]     --keep: leave the temporary folder for inspection
# Exits non-zero, naming what is missing, when any of it fails.
set -euo pipefail
src="$(cd "$(dirname "$0")/.." && pwd)"
keep=0
[ "${1:-}" = "--keep" ] && keep=1
tmp="$(mktemp -d -t dqn_dovs_clone_XXXXXX)"
cleanup() { if [ $keep -eq 0 ]; then rm -rf "$tmp"; else echo "[clone] kept $tmp"; fi; }
trap cleanup EXIT
clone="$tmp/dqn_dovs"
echo "[clone] git clone $src -> $clone (committed HEAD $(git -C "$src" rev-parse --short HEAD))"
git clone -q --no-hardlinks "$src" "$clone"
[ -z "$(ls -A "$tmp" | grep -v '^dqn_dovs$' || true)" ] || { echo "[clone] the temporary folder is not empty" >&2; exit 1; }
cd "$clone"
t0=$(date +%s)
if ! make demo >"$tmp/demo.log" 2>&1; then
  echo "[clone] FAILED: make demo in the clean clone (last lines of its output):" >&2
  tail -30 "$tmp/demo.log" >&2
  exit 1
fi
t1=$(date +%s)
grep -E "^demo:" "$tmp/demo.log"
fail=0
for f in out/demo/trajectories.png out/demo/demo.bag; do
  [ -s "$f" ] || { echo "[clone] FAILED: $f was not written" >&2; fail=1; }
done
grep -qE "^demo: [1-9][0-9]*/[0-9]+ reached the goal" "$tmp/demo.log" || { echo "[clone] FAILED: no goal reached" >&2; fail=1; }
if grep -q "Traceback" "$tmp/demo.log"; then echo "[clone] FAILED: a Python traceback in the output" >&2; fail=1; fi
echo "[clone] make demo in a clean clone: $((t1 - t0)) s (set-up, build and demo)"
[ $fail -eq 0 ] && echo "[clone] ok"
exit $fail

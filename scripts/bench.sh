#!/usr/bin/env bash
# Runs one benchmark by name from the repository root; its figures land in bench/results/NAME.json.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
name="$1"
file_name="${name//-/_}"
mkdir -p bench/results
exe="install/lib/dqn_dovs/bench_${file_name}"
py="bench/bench_${file_name}.py"
sh="bench/bench_${file_name}.sh"
# The installed tools find the core library through the install tree.
export LD_LIBRARY_PATH="$(pwd)/install/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
# Peak memory: GNU time writes the max RSS (KiB) of the benchmark process (and of the children it waited for)
# to bench/results/NAME.rss_kb; docs/performance.md reports it. Without /usr/bin/time the run is not wrapped.
rss="bench/results/${name}.rss_kb"
rm -f "$rss"
measure=()
if [ -x /usr/bin/time ]; then measure=(/usr/bin/time -f %M -o "$rss"); fi
# The load average when the benchmark started: the machine may be shared.
cut -d' ' -f1-3 /proc/loadavg >"bench/results/${name}.loadavg" 2>/dev/null || true
echo "=== bench ${name} ==="
if [ -x "$exe" ]; then
  "${measure[@]}" "$exe" --out "bench/results/${name}.json"
elif [ -f "$py" ]; then
  PYTHONPATH="$(pwd)/python" DQN_DOVS_BIN_DIR="$(pwd)/install/lib/dqn_dovs" "${measure[@]}" .venv/bin/python "$py" --out "bench/results/${name}.json"
elif [ -f "$sh" ]; then
  "${measure[@]}" bash "$sh" "bench/results/${name}.json"
else
  echo "unknown benchmark '${name}' (no $exe, $py or $sh)" >&2; exit 2
fi

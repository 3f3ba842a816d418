#!/usr/bin/env bash
# Runs one benchmark by name from the repository root; its figures land in bench/results/NAME.json.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
name="$1"
file_name="${name//-/_}"
mkdir -p bench/results
exe="install/lib/dqn_dovs/bench_${file_name}"
py="bench/bench_${file_name}.py"
sh="bench/bench_${file_name}.sh"
echo "=== bench ${name} ==="
if [ -x "$exe" ]; then
  "$exe" --out "bench/results/${name}.json"
elif [ -f "$py" ]; then
  PYTHONPATH="$(pwd)/python" DQN_DOVS_BIN_DIR="$(pwd)/install/lib/dqn_dovs" .venv/bin/python "$py" --out "bench/results/${name}.json"
elif [ -f "$sh" ]; then
  bash "$sh" "bench/results/${name}.json"
else
  echo "unknown benchmark '${name}' (no $exe, $py or $sh)" >&2; exit 2
fi

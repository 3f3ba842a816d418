#!/usr/bin/env bash
# colcon build of the package at the repository root; quiet unless something fails.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
export MAKEFLAGS="-j${JOBS:-2}"
log=log/build.last.txt
mkdir -p log
if ! colcon build --base-paths . --build-base build --install-base install --merge-install \
      --event-handlers console_start_end- \
      --cmake-args -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON $(ccache_args) >"$log" 2>&1; then
  echo "[build] colcon build failed; last lines of $log:" >&2
  grep -E "error|Error|FAILED" "$log" | head -40 >&2 || true
  tail -40 "$log" >&2
  exit 1
fi
# The trainer imports the compiled core as dqn_dovs_py._core from python/dqn_dovs_py.
so=$(find build/dqn_dovs/python/dqn_dovs_py -maxdepth 1 -name '_core*.so' 2>/dev/null | head -n1 || true)
if [ -n "$so" ]; then ln -sf "$(pwd)/$so" python/dqn_dovs_py/; fi
echo "[build] ok"

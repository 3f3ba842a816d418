#!/usr/bin/env bash
# make format-check: every C++ source and header (include src test bench tools fuzz) is formatted as
# .clang-format says (make format applies it). Lists the files that are not and exits 1; exits 0 when all are.
set -uo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/env.sh
. scripts/env.sh
command -v clang-format >/dev/null || { echo "format-check: clang-format is not installed (make setup)" >&2; exit 2; }
mapfile -t files < <(find include src test bench tools fuzz \( -name '*.cpp' -o -name '*.h' \) -type f | sort)
bad=()
for f in "${files[@]}"; do
  clang-format --dry-run --Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if [ ${#bad[@]} -gt 0 ]; then
  echo "format-check: ${#bad[@]} of ${#files[@]} files are not formatted (run 'make format'):"
  printf '  %s\n' "${bad[@]}"
  exit 1
fi
echo "format-check: ${#files[@]} files formatted"

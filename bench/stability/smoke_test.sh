#!/usr/bin/env bash
# CTest smoke test of stability_sweep (path in $1): --quick exits 0 (no silent failure) and writes
# both files; the plot script runs on the CSV where Debian's matplotlib is installed.
set -euo pipefail
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$1" --quick --csv "$dir/stability.csv" --markdown "$dir/stability.md"
test -s "$dir/stability.csv"
test -s "$dir/stability.md"
head -1 "$dir/stability.csv" | grep -q '^sweep,robot,gravity,x,precision,'
grep -q 'Trustworthy region' "$dir/stability.md"
if /usr/bin/python3 -c 'import matplotlib' 2>/dev/null; then
  /usr/bin/python3 "$(dirname "$0")/plot_stability.py" "$dir/stability.csv" "$dir/stability.png"
  test -s "$dir/stability.png"
fi

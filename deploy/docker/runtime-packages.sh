#!/usr/bin/env bash
# Prints the Debian packages that hold the shared libraries the given binaries and plugins link,
# one a line, sorted: what the image's runtime stage installs (the build stage runs this on the
# installed files), so the list follows the code's dependencies instead of a list kept by hand.
# Our own libraries (librbdgrad_*) are skipped: they are copied from the build. Libraries the
# code loads with dlopen (NVRTC) do not show here: the Dockerfile names those.
# Fails when a file is not a dynamic executable or library, or a library is not found or
# belongs to no package.
set -euo pipefail
[[ $# -gt 0 ]] || { echo "usage: $0 FILE..." >&2; exit 2; }

status=0
declare -A libs=()
for file in "$@"; do
  if ! out=$(ldd "$file" 2>&1); then
    echo "$0: $file: $out" >&2
    status=1
    continue
  fi
  while read -r line; do
    if [[ $line == *"=> not found"* ]]; then
      echo "$0: $file: ${line%% *} not found" >&2
      status=1
    elif [[ $line =~ =\>\ (/[^ ]+) ]]; then
      lib=$(realpath -s "${BASH_REMATCH[1]}")  # /lib/x/../../lib/x/libfoo.so -> /lib/x/libfoo.so
      [[ $(basename "$lib") == librbdgrad_* ]] || libs[$lib]=1
    fi
  done <<<"$out"
done
[[ $status -eq 0 ]] || exit "$status"

# Debian 12 has merged /usr, but dpkg knows each file under one spelling: ask for both, in one
# call (dpkg-query is slow to start); it exits non-zero for the spellings it does not know.
candidates=()
for lib in "${!libs[@]}"; do
  candidates+=("$lib")
  if [[ $lib == /usr/* ]]; then candidates+=("${lib#/usr}"); else candidates+=("/usr$lib"); fi
done
declare -A owner=()
while IFS= read -r line; do
  [[ $line == *": /"* ]] || continue     # "libfoo1:amd64: /usr/lib/x/libfoo.so.1"
  path=${line##*: }
  package=${line%%: /*}
  owner[$path]=${package%%:*}            # drop the architecture
done < <(dpkg-query -S "${candidates[@]}" 2>/dev/null || true)

declare -A packages=()
for lib in "${!libs[@]}"; do
  other=$([[ $lib == /usr/* ]] && echo "${lib#/usr}" || echo "/usr$lib")
  package=${owner[$lib]:-${owner[$other]:-}}
  if [[ -z $package ]]; then
    echo "$0: $lib belongs to no Debian package" >&2
    status=1
  else
    packages[$package]=1
  fi
done
[[ $status -eq 0 ]] || exit "$status"
printf '%s\n' "${!packages[@]}" | sort

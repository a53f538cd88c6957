#!/usr/bin/env bash
# Packs what a lent GPU machine needs to check the CUDA plugin (the `device` tool's machines have
# CUDA 13 and its tools, not the project's Debian libraries): a portable Release build for sm_90,
# its CUDA test and benchmark programs, the daemon and the CLI, the plugin, the shared libraries
# they load beyond the C and C++ runtimes and CUDA's, and scripts/gpu-checks.sh, which runs them
# there; the programs stripped of symbols (the device tool carries 64 MiB with the working tree).
# Builds in build-cuda/portable and writes build-gpu-bundle/, and the same packed in
# build-gpu-bundle-packed/bundle.tgz (all ignored by git; it says which to carry).
# Each REV given adds that commit's cuda_batch_bench (bin/cuda_batch_bench-REV, built from a
# worktree in build-cuda/), which gpu-checks.sh times against this one's default kernel.
#
#   scripts/gpu-bundle.sh [REV ...]  # then, on the GPU machine, what it prints after "run:"
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

build="build-cuda/portable"
bundle="build-gpu-bundle"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DRBDGRAD_NATIVE=OFF -DRBDGRAD_BUILD_BENCH=ON >/dev/null
programs=(tests/plugins/cuda/plugin_cuda_tests tests/plugins/cuda/plugin_cuda_specialized_kernel_tests
          tests/plugins/cuda/plugin_cuda_kernel_choice_tests bench/cuda_batch_bench bench/cuda_flop_count
          server/rbdgradd tools/rbdgrad)
targets=()
for p in "${programs[@]}"; do targets+=("$(basename "$p")"); done
cmake --build "$build" -j"$(nproc)" --target "${targets[@]}" rbdgrad_cuda

rm -rf "$bundle"
mkdir -p "$bundle/bin" "$bundle/lib"
for p in "${programs[@]}"; do cp "$build/$p" "$bundle/bin/"; done
cp "$build/plugins/cuda/librbdgrad_cuda.so" "$bundle/lib/"
for rev in "$@"; do
  name=$(git rev-parse --short "$rev^{commit}")
  tree="build-cuda/src-$name"
  [[ -d "$tree" ]] || git worktree add --detach "$tree" "$name" >/dev/null
  cmake -S "$tree" -B "build-cuda/rev-$name" -DCMAKE_BUILD_TYPE=Release -DRBDGRAD_NATIVE=OFF \
    -DRBDGRAD_BUILD_BENCH=ON >/dev/null
  cmake --build "build-cuda/rev-$name" -j"$(nproc)" --target cuda_batch_bench
  cp "build-cuda/rev-$name/bench/cuda_batch_bench" "$bundle/bin/cuda_batch_bench-$name"
done
# the libraries the GPU machine's image lacks: everything but the C and C++ runtimes and CUDA's
for f in "$bundle"/bin/* "$bundle"/lib/librbdgrad_cuda.so; do
  ldd "$f" | awk '$3 ~ /^\// {print $3}'
done | sort -u | grep -Ev '/(libc|libm|libgcc_s|libstdc\+\+|libpthread|libdl|librt|ld-linux[^/]*|libcuda|libnvrtc)\.so' |
  while read -r lib; do cp -L "$lib" "$bundle/lib/"; done
cp scripts/gpu-checks.sh "$bundle/"
# the tests read their data from the source tree's path at build time, and load the plugin from
# the build's path
sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt" >"$bundle/source_dir"
echo "$PWD/$build/plugins/cuda/librbdgrad_cuda.so" >"$bundle/plugin_path"
git rev-parse --short HEAD >"$bundle/commit"
git diff --quiet HEAD || echo "(with uncommitted changes)" >>"$bundle/commit"
# the device tool carries at most 64 MiB with the working tree: symbols off the programs (what
# runs is the same), and the bundle also packed (gzip: about 40% of its size), for a bundle with
# several REVs that does not fit unpacked
strip --strip-unneeded "$bundle"/bin/* "$bundle/lib/librbdgrad_cuda.so"
packed="build-gpu-bundle-packed"
rm -rf "$packed"
mkdir -p "$packed"
tar czf "$packed/bundle.tgz" "$bundle"
mib=$((1024 * 1024))
bundle_bytes=$(du -sb "$bundle" | cut -f1)
packed_bytes=$(du -sb "$packed" | cut -f1)
tree_bytes=$(git ls-files -z -co --exclude-standard | du -cb --files0-from=- 2>/dev/null | tail -n 1 | cut -f1)
echo "bundle: $((bundle_bytes / mib)) MiB in $bundle/, $((packed_bytes / mib)) MiB packed in $packed/bundle.tgz;" \
  "the working tree $((tree_bytes / mib)) MiB"
if ((bundle_bytes + tree_bytes <= 64 * mib)); then
  echo "run: carry [\"$bundle\"]; bash $bundle/gpu-checks.sh"
elif ((packed_bytes + tree_bytes <= 64 * mib)); then
  echo "run: carry [\"$packed\"]; tar xzf $packed/bundle.tgz && bash $bundle/gpu-checks.sh" \
    "(unpacked it exceeds the device tool's 64 MiB)"
else
  echo "warning: even packed, the bundle and the working tree exceed the device tool's 64 MiB;" \
    "bundle fewer REVs" >&2
fi

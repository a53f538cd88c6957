#!/usr/bin/env bash
# The tool-driven checks of deploy/ (tests/deploy/CMakeLists.txt runs each as a test):
#   deploy_checks.sh systemd SOURCE_DIR STAND_IN      systemd-analyze verify on the units
#   deploy_checks.sh kustomize SOURCE_DIR             kubectl kustomize renders deploy/kubernetes
#   deploy_checks.sh schema SOURCE_DIR                Kubernetes API schema check (node + npm package)
#   deploy_checks.sh dockerfile SOURCE_DIR            Dockerfile lint (node + npm package)
#   deploy_checks.sh runtime-packages SOURCE_DIR FILE...   the image's package list for FILE...
# A check whose tool is missing exits 77, which CTest reports as skipped, with the reason.
# The two node checks use npm packages installed outside the repository (npm reaches its registry
# here; CI has no node):
#   npm install --prefix DIR kubernetes-models@5.1.0 js-yaml@4 dockerfile-utils@0.16.3
#   RBDGRAD_DEPLOY_NODE_MODULES=DIR/node_modules ctest -L deploy
set -euo pipefail
SKIP=77
check=$1 source_dir=$(realpath "$2")
shift 2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

skip() { echo "SKIPPED: $*"; exit "$SKIP"; }
need_node_modules() {
  command -v node >/dev/null || skip "node is not installed (this check runs on Node.js)"
  modules=${RBDGRAD_DEPLOY_NODE_MODULES:-}
  for package in "$@"; do
    [[ -n $modules && -d $modules/$package ]] ||
      skip "RBDGRAD_DEPLOY_NODE_MODULES does not name a node_modules folder with $*" \
           "(npm install --prefix DIR kubernetes-models@5.1.0 js-yaml@4 dockerfile-utils@0.16.3;" \
           "RBDGRAD_DEPLOY_NODE_MODULES=DIR/node_modules)"
  done
}

case $check in
systemd)
  # verify wants the ExecStart binary to exist: the units point at /usr/local/bin/rbdgradd, which
  # is not installed here, so copies of them point at the binary built here instead.
  stand_in=$(realpath "$1")
  command -v systemd-analyze >/dev/null || skip "systemd-analyze is not installed (Debian package systemd)"
  for unit in rbdgradd.service rbdgradd@.service; do
    sed "s|/usr/local/bin/rbdgradd|$stand_in|" "$source_dir/deploy/systemd/$unit" > "$work/$unit"
  done
  cp "$work/rbdgradd@.service" "$work/rbdgradd@0.service"  # a template is verified as an instance
  # verify exits 0 after warnings such as an unknown key: any output is a failure here
  status=0
  for unit in rbdgradd.service rbdgradd@0.service; do
    if ! out=$(cd "$work" && systemd-analyze verify "./$unit" 2>&1) || [[ -n $out ]]; then
      echo "FAIL systemd-analyze verify $unit:"; echo "$out"; status=1
    else
      echo "ok   systemd-analyze verify $unit: no warning"
    fi
    # the exposure score, for the record (docs/deploy.md quotes it)
    (cd "$work" && systemd-analyze security --offline=yes "./$unit" 2>/dev/null | tail -n 1) || true
  done
  if command -v systemd-sysusers >/dev/null; then
    # installed as the file says, in an empty root
    mkdir -p "$work/root/etc/sysusers.d"
    cp "$source_dir/deploy/systemd/rbdgrad.sysusers.conf" "$work/root/etc/sysusers.d/rbdgrad.conf"
    if systemd-sysusers --root="$work/root" >/dev/null 2>&1 &&
       grep -q '^rbdgrad:' "$work/root/etc/passwd" && grep -q '^rbdgrad:' "$work/root/etc/group"; then
      echo "ok   systemd-sysusers creates user and group rbdgrad from rbdgrad.sysusers.conf"
    else
      echo "FAIL systemd-sysusers on rbdgrad.sysusers.conf"; status=1
    fi
  fi
  exit "$status"
  ;;
kustomize)
  command -v kubectl >/dev/null || skip "kubectl is not installed: kubectl kustomize renders the manifests offline"
  kubectl kustomize "$source_dir/deploy/kubernetes" > "$work/rendered.yaml"
  for kind in ConfigMap Deployment Service PodDisruptionBudget; do
    grep -q "^kind: $kind\$" "$work/rendered.yaml" || { echo "FAIL: no $kind in the rendered manifests"; exit 1; }
  done
  if grep -q '^kind: Secret$' "$work/rendered.yaml"; then
    echo "FAIL: the kustomization applies a Secret (the placeholders would overwrite the real ones)"; exit 1
  fi
  echo "ok   kubectl kustomize deploy/kubernetes: ConfigMap, Deployment, Service, PodDisruptionBudget; no Secret"
  ;;
schema)
  # kubectl cannot validate without a cluster (it downloads the schema from the API server), so
  # the schema comes from the npm package kubernetes-models.
  need_node_modules kubernetes-models js-yaml
  checker=$source_dir/tests/deploy/k8s_schema_check.mjs
  files=("$source_dir"/deploy/kubernetes/*.yaml)
  if command -v kubectl >/dev/null; then
    # also the objects as applied: the kustomization's labels and image on them
    kubectl kustomize "$source_dir/deploy/kubernetes" > "$work/rendered.yaml"
    files+=("$work/rendered.yaml")
  fi
  node "$checker" "$modules" "${files[@]}"
  # the checker must reject known-bad objects, one failure each (tests/deploy/bad_manifests.yaml)
  set +e
  out=$(node "$checker" "$modules" "$source_dir/tests/deploy/bad_manifests.yaml")
  rc=$?
  set -e
  expected=$(grep -c '^kind:' "$source_dir/tests/deploy/bad_manifests.yaml")
  if [[ $rc -ne 1 ]] || ! grep -q "$expected failure(s)\$" <<<"$out"; then
    echo "FAIL: the schema check did not reject the $expected bad objects of bad_manifests.yaml:"; echo "$out"; exit 1
  fi
  echo "ok   the schema check rejects the $expected known-bad objects of tests/deploy/bad_manifests.yaml"
  ;;
dockerfile)
  need_node_modules dockerfile-utils
  node "$source_dir/tests/deploy/dockerfile_lint.mjs" "$modules" "$source_dir/deploy/docker/Dockerfile"
  # ... and it must find the faults of a known-bad one
  printf 'FROM debian:12\nEXPOSE port\nCOPY --frm=build a b\nRUNN true\n' > "$work/Dockerfile"
  if node "$source_dir/tests/deploy/dockerfile_lint.mjs" "$modules" "$work/Dockerfile" >"$work/out" ||
     [[ $(grep -c ':[0-9]*: ' "$work/out") -ne 3 ]]; then
    echo "FAIL: the lint did not find the 3 faults of a known-bad Dockerfile:"; cat "$work/out"; exit 1
  fi
  echo "ok   the lint finds the 3 faults of a known-bad Dockerfile"
  ;;
runtime-packages)
  command -v dpkg-query >/dev/null || skip "dpkg-query is not installed: the image's package list needs a Debian system"
  out=$("$source_dir/deploy/docker/runtime-packages.sh" "$@")
  echo "$out"
  for package in libc6 libstdc++6 libgrpc++1.51 libyaml-cpp0.7; do
    grep -qx "$package" <<<"$out" || { echo "FAIL: $package is not in the list"; exit 1; }
  done
  echo "ok   the binaries' libraries all come from Debian packages: $(wc -l <<<"$out") packages"
  ;;
*)
  echo "usage: deploy_checks.sh systemd|kustomize|schema|dockerfile|runtime-packages SOURCE_DIR ..." >&2
  exit 2
  ;;
esac

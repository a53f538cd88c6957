#!/usr/bin/env python3
"""Cross-file checks of deploy/: the values that must agree between the daemon's configuration,
the Kubernetes manifests, the image and the systemd units (paths, ports, names, the drain time
against the grace periods). Each check prints one line; any failure fails the test.

usage: check_consistency.py SOURCE_DIR
Needs PyYAML (Debian: python3-yaml); without it the test is skipped (exit 77).
"""
import os
import re
import sys

SKIP = 77
try:
    import yaml
except ImportError:
    print("SKIPPED: PyYAML is not installed (Debian package python3-yaml): the cross-file checks "
          "of deploy/ need it to read the manifests")
    sys.exit(SKIP)

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def read(root, rel):
    with open(os.path.join(root, rel)) as f:
        return f.read()


def under(path, folder):
    return os.path.commonpath([path, folder]) == folder


def drain_seconds(root):
    """The daemon's longest stop after SIGTERM: its grace for requests in flight plus the time
    it gives connections to close (server/daemon.hpp, server/daemon.cpp)."""
    grace = re.search(r"shutdown_grace\{([\d']+)\}", read(root, "server/daemon.hpp"))
    close = re.search(r"kCloseGrace\{([\d']+)\}", read(root, "server/daemon.cpp"))
    if not grace or not close:
        raise SystemExit("cannot find shutdown_grace / kCloseGrace in server/daemon.{hpp,cpp}")
    return (int(grace.group(1).replace("'", "")) + int(close.group(1).replace("'", ""))) / 1000.0


def unit_settings(text):
    settings = {}
    for line in text.splitlines():
        m = re.match(r"^([A-Za-z]+)=(.*)$", line)
        if m:
            settings.setdefault(m.group(1), []).append(m.group(2))
    return settings


def seconds(value):
    m = re.fullmatch(r"(\d+)(s|min)?", value)
    return int(m.group(1)) * (60 if m.group(2) == "min" else 1)


def main():
    root = sys.argv[1]
    drain = drain_seconds(root)
    print(f"the daemon's drain after SIGTERM: at most {drain} s (server/daemon.*)")
    k8s = "deploy/kubernetes"
    docs = {}
    for name in ("configmap.yaml", "deployment.yaml", "service.yaml", "poddisruptionbudget.yaml", "secret.yaml"):
        for doc in yaml.safe_load_all(read(root, f"{k8s}/{name}")):
            if doc:
                docs[(doc["kind"], doc["metadata"]["name"])] = doc
    deployment = docs[("Deployment", "rbdgradd")]
    pod = deployment["spec"]["template"]["spec"]
    container = pod["containers"][0]
    mounts = {m["name"]: m["mountPath"] for m in container["volumeMounts"]}
    volumes = {v["name"]: v for v in pod["volumes"]}
    writable = [mounts[n] for n, v in volumes.items() if "emptyDir" in v]

    # the configuration the pods read
    config_volume = next(n for n, v in volumes.items() if "configMap" in v)
    configmap = docs.get(("ConfigMap", volumes[config_volume]["configMap"]["name"]))
    check(configmap is not None, f"the config volume's ConfigMap {volumes[config_volume]['configMap']['name']} is in configmap.yaml")
    args = container["args"]
    config_path = args[args.index("--config") + 1]
    key = os.path.relpath(config_path, mounts[config_volume])
    check(key in configmap["data"], f"--config {config_path} is a key of the ConfigMap mounted at {mounts[config_volume]}")
    config = yaml.safe_load(configmap["data"][key])

    # the Unix socket and the probes
    socket = config["listen"]["unix_socket"]
    check(any(under(socket, w) for w in writable), f"listen.unix_socket {socket} is on a writable emptyDir")
    for probe in ("startupProbe", "readinessProbe", "livenessProbe"):
        command = container[probe]["exec"]["command"]
        check(f"unix:{socket}" in command and command[-1] == "health",
              f"{probe} runs `rbdgrad --server unix:{socket} health`")
    dockerfile = read(root, "deploy/docker/Dockerfile")
    check(f'"unix:{socket}", "health"' in dockerfile, f"the image's HEALTHCHECK asks unix:{socket}")
    check(container["securityContext"]["readOnlyRootFilesystem"] is True, "the root file system is read-only")
    calibration = config["scheduler"]["calibration_file"]
    check(any(under(calibration, w) for w in writable), f"scheduler.calibration_file {calibration} is on a writable emptyDir")
    xdg = re.search(r"XDG_CACHE_HOME=(\S+)", dockerfile).group(1)
    check(any(under(os.path.join(xdg, "rbdgrad"), w) for w in writable),
          f"the CUDA kernel cache ($XDG_CACHE_HOME/rbdgrad = {xdg}/rbdgrad) is on a writable emptyDir")

    # TLS and tokens: each file is a key of a Secret mounted at its folder
    secret_mounts = {mounts[n]: v["secret"]["secretName"] for n, v in volumes.items() if "secret" in v}
    for section, field in (("tls", "cert_file"), ("tls", "key_file"), ("tls", "client_ca_file"), ("auth", "tokens_file")):
        path = config[section][field]
        if not path:
            continue
        folder, name = os.path.split(path)
        secret = docs.get(("Secret", secret_mounts.get(folder, "?")))
        check(secret is not None and name in secret.get("stringData", {}),
              f"{section}.{field} {path} is key {name} of the Secret mounted at {folder}")
    ca = docs[("Secret", "rbdgradd-tls")]["stringData"]
    check("ca.crt" in ca, "the TLS Secret has ca.crt, for tls.client_ca_file (mutual TLS)")

    # ports, names, selectors
    port = int(config["listen"]["tcp"].rsplit(":", 1)[1])
    grpc_port = next(p for p in container["ports"] if p["name"] == "grpc")
    check(grpc_port["containerPort"] == port, f"the container port named grpc is listen.tcp's port {port}")
    check(f"EXPOSE {port}" in dockerfile, f"the image exposes {port}")
    service = docs[("Service", "rbdgradd-headless")]
    check(service["spec"]["clusterIP"] == "None", "the Service is headless")
    check(service["spec"]["ports"][0]["port"] == port and service["spec"]["ports"][0]["targetPort"] == "grpc",
          f"the Service's port {port} goes to the port named grpc")
    labels = deployment["spec"]["template"]["metadata"]["labels"]
    for kind, name, selector in (("Service", "rbdgradd-headless", service["spec"]["selector"]),
                                 ("Deployment", "rbdgradd", deployment["spec"]["selector"]["matchLabels"]),
                                 ("PodDisruptionBudget", "rbdgradd",
                                  docs[("PodDisruptionBudget", "rbdgradd")]["spec"]["selector"]["matchLabels"])):
        check(selector.items() <= labels.items(), f"the {kind} {name} selects the pods ({selector})")

    # resources
    requests, limits = container["resources"]["requests"], container["resources"]["limits"]
    check(str(limits.get("nvidia.com/gpu")) == "1", "each pod asks for one GPU (nvidia.com/gpu: 1)")
    check(requests == limits, "requests equal limits (Guaranteed QoS)")
    check(str(config["workers"]) == str(requests["cpu"]), f"workers ({config['workers']}) = the CPU request ({requests['cpu']})")
    check(deployment["spec"]["replicas"] >= 2, f"several replicas ({deployment['spec']['replicas']})")
    uid = re.search(r"^USER (\d+):(\d+)", dockerfile, re.M)
    check(uid and int(uid.group(1)) == pod["securityContext"]["runAsUser"], "runAsUser is the image's USER")

    # drain against the grace period
    pre_stop = container["lifecycle"]["preStop"]["exec"]["command"]
    sleep = int(pre_stop[-1]) if pre_stop[0].endswith("sleep") else 0
    grace = pod["terminationGracePeriodSeconds"]
    check(grace >= sleep + drain + 5,
          f"terminationGracePeriodSeconds {grace} >= preStop sleep {sleep} + drain {drain} + 5 s margin")

    # kustomization: every resource exists; the placeholder Secrets are not applied
    kustomization = yaml.safe_load(read(root, f"{k8s}/kustomization.yaml"))
    check(all(os.path.exists(os.path.join(root, k8s, r)) for r in kustomization["resources"]),
          "every kustomization resource exists")
    check("secret.yaml" not in kustomization["resources"], "kustomization.yaml leaves the placeholder secret.yaml out")
    image = container["image"].rsplit(":", 1)[0]
    check(any(i["name"] == image for i in kustomization.get("images", [])), f"kustomization.yaml sets the image {image}")

    # systemd
    example = yaml.safe_load(read(root, "deploy/systemd/rbdgradd.yaml"))
    for unit in ("rbdgradd.service", "rbdgradd@.service"):
        s = unit_settings(read(root, f"deploy/systemd/{unit}"))
        stop = seconds(s["TimeoutStopSec"][0])
        check(stop >= drain + 5, f"{unit}: TimeoutStopSec {stop} s >= drain {drain} + 5 s margin")
        runtime = "/run/" + s["RuntimeDirectory"][0]
        cache = "/var/cache/" + s["CacheDirectory"][0]
        if unit == "rbdgradd.service":
            check(s["ExecStart"][0].split()[1:3] == ["--config", "/etc/rbdgrad/rbdgradd.yaml"],
                  f"{unit} reads /etc/rbdgrad/rbdgradd.yaml")
            sock = example["listen"]["unix_socket"]
        else:
            sock = re.search(r"--unix-socket (\S+)", s["ExecStart"][0]).group(1)
        check(under(sock, runtime), f"{unit}: the Unix socket {sock} is in its RuntimeDirectory {runtime}")
        check(under(example["scheduler"]["calibration_file"], cache),
              f"{unit}: the example's calibration file is in its CacheDirectory {cache}")
        check(s.get("Environment", []).count("XDG_CACHE_HOME=%C") == 1 and s["CacheDirectory"][0] == "rbdgrad",
              f"{unit}: the CUDA kernel cache ($XDG_CACHE_HOME/rbdgrad) is its CacheDirectory")
        check(s.get("UMask") == ["0007"] and s.get("Group") == ["rbdgrad"],
              f"{unit}: the socket is usable by group rbdgrad (UMask 0007)")
        check(s.get("CapabilityBoundingSet") == [""] and s.get("NoNewPrivileges") == ["yes"],
              f"{unit}: no capabilities, no new privileges")

    print(f"{len(failures)} failure(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env bash
# make_noop_xclbin.sh OUT.xclbin
#
# Writes a metadata-only xclbin describing the one kernel rbdgrad_fpga_gradient (a compute unit
# rbdgrad_fpga_gradient_1, arguments robot_words/in on bank0 (gmem0), out on bank1 (gmem1),
# n_states and mode as scalars). It is for exercising the FPGA plugin's XRT host path under
# XRT's noop shim (XCL_EMULATION_MODE=noop): with it, device.load_xclbin, xrt::kernel, group_id,
# xrt::bo, sync, kernel start/wait and xrt::run reuse all run against Debian's XRT 2.13 without a
# device. It contains NO bitstream and no emulation model: it is not a hardware xclbin, nothing
# computes with it (the noop shim completes every run without touching the buffers), and it can
# not program a card or run under sw_emu/hw_emu. The real xclbin comes from Makefile.vitis.
#
# Sources (noop/): ip_layout.json, mem_topology.json, connectivity.json, clock_freq_topology.json
# in xclbinutil's JSON section format, and kernel.xml (the EMBEDDED_METADATA XRT reads the
# kernel's arguments from). The offsets in kernel.xml must stay consistent with ip_layout.json
# (CU base address) and connectivity.json (argument -> memory bank).
#
# Assembler: make_noop_xclbin.py (Python 3, standard library only), because Debian 12's
# libxrt-utils ships /usr/bin/xclbinutil as a wrapper script whose binary
# (/usr/bin/unwrapped/xclbinutil) is missing (and the wrapper then exits 0). With
# RBDGRAD_XCLBINUTIL=/path/to/a/working/xclbinutil (e.g. from an XRT install in /opt/xilinx/xrt)
# the same sources are assembled by xclbinutil instead; that path has NOT been tried here (no
# working xclbinutil was available), and xclbinutil inserts its own random UUID.
#
# Writes only OUT.xclbin. Exit status 0 on success, 1 on any failure (OUT may then be partial).
set -euo pipefail

if [[ $# -ne 1 || -z "$1" ]]; then
  echo "usage: $0 OUT.xclbin" >&2
  exit 1
fi
out=$1
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
src=$here/noop

if [[ -n "${RBDGRAD_XCLBINUTIL:-}" ]]; then
  "$RBDGRAD_XCLBINUTIL" --quiet --force \
    --add-section "MEM_TOPOLOGY:JSON:$src/mem_topology.json" \
    --add-section "CONNECTIVITY:JSON:$src/connectivity.json" \
    --add-section "IP_LAYOUT:JSON:$src/ip_layout.json" \
    --add-section "CLOCK_FREQ_TOPOLOGY:JSON:$src/clock_freq_topology.json" \
    --add-section "EMBEDDED_METADATA:RAW:$src/kernel.xml" \
    --output "$out"
else
  "${PYTHON:-python3}" "$here/make_noop_xclbin.py" --output "$out" \
    --mem-topology "$src/mem_topology.json" \
    --connectivity "$src/connectivity.json" \
    --ip-layout "$src/ip_layout.json" \
    --clock-freq-topology "$src/clock_freq_topology.json" \
    --embedded-metadata "$src/kernel.xml"
fi

# a wrapper that exits 0 without doing anything must not pass for success
if [[ ! -s "$out" || "$(head -c 7 "$out")" != "xclbin2" ]]; then
  echo "$0: no xclbin was written to $out" >&2
  exit 1
fi

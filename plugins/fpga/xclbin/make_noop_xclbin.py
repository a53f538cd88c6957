#!/usr/bin/env python3
"""Assemble a metadata-only xclbin (axlf container) from xclbinutil-style JSON sections.

Written for rbdgrad (see make_noop_xclbin.sh, which calls it): Debian 12's libxrt-utils ships
/usr/bin/xclbinutil as a wrapper script whose binary (/usr/bin/unwrapped/xclbinutil) is missing,
so the container is written here, following the structures of XRT's public header
/usr/include/xrt/xclbin.h (struct axlf, axlf_header, axlf_section_header, ip_layout, mem_topology,
connectivity, clock_freq_topology). It reads the same JSON that `xclbinutil --add-section
KIND:JSON:file` takes, for the fields these sections use, and copies EMBEDDED_METADATA raw.

The result has no bitstream: it is only for exercising the XRT host path under the noop shim
(XCL_EMULATION_MODE=noop). It is not a hardware xclbin and no device could be programmed with it.

Standard library only. Deterministic: the xclbin UUID is derived from the section contents and the
timestamp is 0 (or SOURCE_DATE_EPOCH), so the same sources give the same bytes.
"""
import argparse
import hashlib
import json
import os
import struct
import sys

# enum axlf_section_kind (xclbin.h)
EMBEDDED_METADATA = 2
MEM_TOPOLOGY = 6
CONNECTIVITY = 7
IP_LAYOUT = 8
CLOCK_FREQ_TOPOLOGY = 11

MEM_TYPES = {"MEM_DDR3": 0, "MEM_DDR4": 1, "MEM_DRAM": 2, "MEM_STREAMING": 3, "MEM_PREALLOCATED_GLOB": 4,
             "MEM_ARE": 5, "MEM_HBM": 6, "MEM_BRAM": 7, "MEM_URAM": 8, "MEM_STREAMING_CONNECTION": 9,
             "MEM_HOST": 10, "MEM_PS_KERNEL": 11}
IP_TYPES = {"IP_MB": 0, "IP_KERNEL": 1, "IP_DNASC": 2, "IP_DDR4_CONTROLLER": 3, "IP_MEM_DDR4": 4,
            "IP_MEM_HBM": 5, "IP_MEM_HBM_ECC": 6, "IP_PS_KERNEL": 7}
IP_CONTROLS = {"AP_CTRL_HS": 0, "AP_CTRL_CHAIN": 1, "AP_CTRL_NONE": 2, "AP_CTRL_ME": 3, "ACCEL_ADAPTER": 4,
               "FAST_ADAPTER": 5}
CLOCK_TYPES = {"UNUSED": 0, "DATA": 1, "KERNEL": 2, "SYSTEM": 3}


class Error(Exception):
    pass


def num(value):
    """A JSON number or a string in C notation (decimal or 0x hex), as xclbinutil takes it."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, int):
        return value
    text = str(value).strip().lower()
    if text in ("true", "false"):
        return int(text == "true")
    return int(text, 0)


def fixed_string(text, size, what):
    raw = text.encode("ascii")
    if len(raw) >= size:
        raise Error(f"{what} '{text}' is longer than {size - 1} characters")
    return raw + b"\0" * (size - len(raw))


def entries(node, key, count_key="m_count"):
    items = node[key]
    if num(node[count_key]) != len(items):
        raise Error(f"{count_key} {node[count_key]} does not match the {len(items)} entries of {key}")
    return items


def ip_layout(doc):
    node = doc["ip_layout"]
    out = struct.pack("<i4x", num(node["m_count"]))
    for ip in entries(node, "m_ip_data"):
        kind = IP_TYPES[ip["m_type"]]
        props = num(ip.get("properties", "0"))
        if kind == IP_TYPES["IP_KERNEL"]:
            if "m_int_enable" in ip:
                props = (props & ~0x1) | (1 if num(ip["m_int_enable"]) else 0)
            if "m_interrupt_id" in ip:
                irq = num(ip["m_interrupt_id"])
                if irq > 0x7F:
                    raise Error(f"m_interrupt_id {irq} > 127")
                props = (props & ~0xFE) | (irq << 1)
            if "m_ip_control" in ip:
                props = (props & ~0xFF00) | (IP_CONTROLS[ip["m_ip_control"]] << 8)
        base = ip["m_base_address"]
        base = 0xFFFFFFFFFFFFFFFF if base == "not_used" else num(base)
        out += struct.pack("<IIQ", kind, props, base) + fixed_string(ip["m_name"], 64, "ip_data.m_name")
    return out


def mem_topology(doc):
    node = doc["mem_topology"]
    out = struct.pack("<i4x", num(node["m_count"]))
    for mem in entries(node, "m_mem_data"):
        if "m_size" in mem and "m_sizeKB" in mem:
            raise Error("m_size and m_sizeKB are mutually exclusive")
        if "m_size" in mem:
            size = num(mem["m_size"])
            if size % 1024:
                raise Error(f"m_size {size} is not a multiple of 1024")
            size //= 1024
        else:
            size = num(mem.get("m_sizeKB", "0"))
        out += struct.pack("<BB6xQQ", MEM_TYPES[mem["m_type"]], num(mem["m_used"]), size,
                           num(mem.get("m_base_address", "0")))
        out += fixed_string(mem["m_tag"], 16, "mem_data.m_tag")
    return out


def connectivity(doc):
    node = doc["connectivity"]
    out = struct.pack("<i", num(node["m_count"]))
    for c in entries(node, "m_connection"):
        out += struct.pack("<iii", num(c["arg_index"]), num(c["m_ip_layout_index"]), num(c["mem_data_index"]))
    return out


def clock_freq_topology(doc):
    node = doc["clock_freq_topology"]
    out = struct.pack("<h", num(node["m_count"]))
    for c in entries(node, "m_clock_freq"):
        out += struct.pack("<HB5x", num(c["m_freq_Mhz"]), CLOCK_TYPES[c["m_type"]])
        out += fixed_string(c["m_name"], 128, "clock_freq.m_name")
    return out


def align8(n):
    return (n + 7) & ~7


def assemble(sections, vbnv):
    """sections: list of (kind, payload bytes). Returns the xclbin bytes."""
    axlf_size = 456  # offsetof(struct axlf, m_sections)
    section_header_size = 40
    offset = align8(axlf_size + section_header_size * len(sections))
    headers = b""
    body = b""
    for kind, payload in sections:
        headers += struct.pack("<I16s4xQQ", kind, b"", offset + len(body), len(payload))
        body += payload + b"\0" * (align8(len(payload)) - len(payload))
    total = offset + len(body)
    digest = bytearray(hashlib.sha256(b"".join(p for _, p in sections)).digest()[:16])
    digest[6] = (digest[6] & 0x0F) | 0x50  # shaped as a name-based UUID (version 5, RFC 4122 variant)
    digest[8] = (digest[8] & 0x3F) | 0x80
    stamp = int(os.environ.get("SOURCE_DATE_EPOCH", "0"))
    header = struct.pack("<QQQHBBHH16s64s16s16sI4x",
                         total,        # m_length
                         stamp,        # m_timeStamp
                         0,            # m_featureRomTimeStamp
                         0, 2, 13,     # m_versionPatch, m_versionMajor, m_versionMinor
                         0,            # m_mode: XCLBIN_FLAT
                         0,            # m_actionMask
                         b"\0" * 16,   # rom / rom_uuid
                         fixed_string(vbnv, 64, "platform VBNV"),
                         bytes(digest),  # uuid
                         b"\0" * 16,   # m_debug_bin
                         len(sections))
    assert len(header) == 152
    prefix = (b"xclbin2\0" + struct.pack("<i", -1) + b"\xff" * 28  # magic, no signature, reserved
              + b"\xff" * 256 + struct.pack("<Q", 0))  # m_keyBlock, m_uniqueId
    out = prefix + header + headers
    out += b"\0" * (offset - len(out)) + body
    assert len(out) == total
    return out


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--output", required=True)
    p.add_argument("--ip-layout", required=True)
    p.add_argument("--mem-topology", required=True)
    p.add_argument("--connectivity", required=True)
    p.add_argument("--clock-freq-topology")
    p.add_argument("--embedded-metadata", required=True, help="kernel XML, copied raw")
    p.add_argument("--vbnv", default="rbdgrad:noop:metadata_only:0")
    a = p.parse_args(argv)

    def load(path):
        with open(path, encoding="utf-8") as f:
            return json.load(f)

    try:
        sections = [
            (MEM_TOPOLOGY, mem_topology(load(a.mem_topology))),
            (CONNECTIVITY, connectivity(load(a.connectivity))),
            (IP_LAYOUT, ip_layout(load(a.ip_layout))),
        ]
        if a.clock_freq_topology:
            sections.append((CLOCK_FREQ_TOPOLOGY, clock_freq_topology(load(a.clock_freq_topology))))
        with open(a.embedded_metadata, "rb") as f:
            sections.append((EMBEDDED_METADATA, f.read()))
        data = assemble(sections, a.vbnv)
    except (Error, KeyError, ValueError, OSError) as e:
        print(f"make_noop_xclbin.py: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    try:
        with open(a.output, "wb") as f:
            f.write(data)
    except OSError as e:
        print(f"make_noop_xclbin.py: cannot write {a.output}: {e.strerror}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

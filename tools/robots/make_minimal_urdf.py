#!/usr/bin/env python3
"""Writes the project's own robot models (robots/*.urdf) from published URDF parameters.

Keeps only what dynamics needs: links with their <inertial>, joints with origin, axis and limits.
Drops meshes, collision shapes, <dynamics> (not modelled), transmissions, sensors and simulator tags.
Usage: make_minimal_urdf.py SOURCE.urdf OUT.urdf "provenance line" ...
"""
import sys
import xml.etree.ElementTree as ET


def attrs(el, keys):
    return " ".join(f'{k}="{el.get(k)}"' for k in keys if el.get(k) is not None)


def main():
    src, out, notes = sys.argv[1], sys.argv[2], sys.argv[3:]
    root = ET.parse(src).getroot()
    lines = ['<?xml version="1.0"?>']
    lines.append("<!-- rbdgrad robot model: links, inertias, joints and limits only.")
    for n in notes:
        lines.append("     " + n)
    lines.append("-->")
    lines.append(f'<robot name="{root.get("name")}">')
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            lines.append(f'  <link name="{link.get("name")}"/>')
            continue
        lines.append(f'  <link name="{link.get("name")}">')
        lines.append("    <inertial>")
        origin = inertial.find("origin")
        if origin is not None:
            lines.append(f"      <origin {attrs(origin, ['xyz', 'rpy'])}/>")
        lines.append(f'      <mass value="{inertial.find("mass").get("value")}"/>')
        lines.append(f"      <inertia {attrs(inertial.find('inertia'), ['ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz'])}/>")
        lines.append("    </inertial>")
        lines.append("  </link>")
    for joint in root.findall("joint"):
        lines.append(f'  <joint name="{joint.get("name")}" type="{joint.get("type")}">')
        lines.append(f'    <parent link="{joint.find("parent").get("link")}"/>')
        lines.append(f'    <child link="{joint.find("child").get("link")}"/>')
        origin = joint.find("origin")
        if origin is not None:
            lines.append(f"    <origin {attrs(origin, ['xyz', 'rpy'])}/>")
        axis = joint.find("axis")
        if axis is not None and joint.get("type") != "fixed":
            lines.append(f'    <axis xyz="{axis.get("xyz")}"/>')
        limit = joint.find("limit")
        if limit is not None and joint.get("type") != "fixed":
            lines.append(f"    <limit {attrs(limit, ['lower', 'upper', 'effort', 'velocity'])}/>")
        lines.append("  </joint>")
    lines.append("</robot>")
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()

"""URDF editing for the engines' exporters: tuned masses, inertias, joint damping and limits in a robot's URDF.

The robot's own URDF (generic values) is edited element by element, so its
kinematics, collision shapes and names stay exactly as the engines loaded them.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from simtune.engines.export_base import num, nums, xml_comment
from simtune.errors import SimtuneError


@dataclass
class Inertial:
    """A link's mass properties: mass, centre of mass and its frame's turn (rpy), inertia about the centre of mass."""

    mass: float
    xyz: np.ndarray
    rpy: np.ndarray
    inertia: np.ndarray  # 3x3 in the (xyz, rpy) frame


def parse(text: str) -> ET.Element:
    return ET.fromstring(text)


def links(root: ET.Element) -> dict[str, ET.Element]:
    return {link.get("name", ""): link for link in root.findall("link")}


def joints(root: ET.Element) -> dict[str, ET.Element]:
    return {joint.get("name", ""): joint for joint in root.findall("joint")}


def set_inertial(link: ET.Element, inertial: Inertial) -> None:
    element = link.find("inertial")
    if element is None:
        element = ET.Element("inertial")
        link.insert(0, element)
    for child in list(element):
        element.remove(child)
    ET.SubElement(element, "origin", xyz=nums(inertial.xyz), rpy=nums(inertial.rpy))
    ET.SubElement(element, "mass", value=num(inertial.mass))
    i = np.asarray(inertial.inertia, dtype=float)
    ET.SubElement(
        element,
        "inertia",
        ixx=num(i[0, 0]),
        ixy=num(i[0, 1]),
        ixz=num(i[0, 2]),
        iyy=num(i[1, 1]),
        iyz=num(i[1, 2]),
        izz=num(i[2, 2]),
    )


def set_damping(joint: ET.Element, damping: float) -> None:
    dynamics = joint.find("dynamics")
    if dynamics is None:
        dynamics = ET.SubElement(joint, "dynamics")
    dynamics.set("damping", num(damping))
    dynamics.set("friction", dynamics.get("friction", "0"))


def set_friction(joint: ET.Element, friction: float) -> None:
    """The joint's Coulomb friction [N m] as URDF's ``<dynamics friction>`` (the ``friction_joint_<n>`` kind).

    Args:
        joint: a URDF ``<joint>`` element.
        friction: the friction torque.

    Returns:
        None; the element gets the attribute.
    """
    dynamics = joint.find("dynamics")
    if dynamics is None:
        dynamics = ET.SubElement(joint, "dynamics", damping="0")
    dynamics.set("friction", num(friction))


def set_limit(joint: ET.Element, effort: float | None = None, velocity: float | None = None) -> None:
    """Effort and velocity limits; a continuous joint gets a <limit> with them (its position stays unlimited)."""
    if joint.get("type") == "fixed":
        raise SimtuneError(f"URDF joint {joint.get('name')!r} is fixed: it has no limits to write")
    limit = joint.find("limit")
    if limit is None:
        limit = ET.SubElement(joint, "limit")
    if effort is not None:
        limit.set("effort", num(effort))
    if velocity is not None:
        limit.set("velocity", num(velocity))


def document(root: ET.Element, header: list[str]) -> str:
    """The URDF text with the provenance header comment."""
    ET.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + xml_comment(header) + ET.tostring(root, encoding="unicode") + "\n"


def single_link(
    name: str, inertial: Inertial, geometry: ET.Element | None, extra: tuple[ET.Element, ...] = ()
) -> ET.Element:
    """A one-link URDF (a free object, the floor): its mass properties and one collision shape."""
    robot = ET.Element("robot", name=name)
    link = ET.SubElement(robot, "link", name=name)
    set_inertial(link, inertial)
    if geometry is not None:
        collision = ET.SubElement(link, "collision")
        ET.SubElement(collision, "origin", xyz="0 0 0", rpy="0 0 0")
        holder = ET.SubElement(collision, "geometry")
        holder.append(geometry)
        for element in extra:
            collision.append(element)
    return robot

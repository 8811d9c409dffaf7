"""The URDF PyBullet loads for a user's robot: the user's file with mesh URIs resolved to absolute paths,
Gazebo `mu1` friction copied into PyBullet's `<contact>`, a 1 g point inertial on links without one
(Gazebo lumps them into their parent; PyBullet would give them 1 kg), and a new root `fleetnav_base` on the floor under
the axle centre (a 1 g point mass, so PyBullet's base pose is exactly fleetnav's base_link, as for the
generated robot in sim.urdf). Written once per distinct content to the temp folder.
"""

from __future__ import annotations

import hashlib
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from sim.resource_path import resolve_resource
from sim.types import Pose3D

BASE = "fleetnav_base"


def _f(v: float) -> str:
    return repr(float(f"{v:.12g}"))


def _token_inertial(link: ET.Element) -> None:
    """A 1 g point mass (a 1 cm sphere's inertia), as sim.urdf gives sensor frames."""
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "mass", value="0.001")
    ET.SubElement(inertial, "inertia", ixx="4e-08", ixy="0", ixz="0", iyy="4e-08", iyz="0", izz="4e-08")


def loadable_urdf_text(text: str, base_dir: Path, root: str, root_in_base: Pose3D,
                       package_path: list[Path] | None = None) -> str:
    robot = ET.fromstring(text.encode("utf-8") if text.lstrip().startswith("<?xml") else text)
    for mesh in robot.iter("mesh"):
        uri = mesh.get("filename", "")
        if uri:
            mesh.set("filename", str(resolve_resource(uri, base_dir, package_path, where=f"mesh '{uri}': ")))
    links = {link.get("name"): link for link in robot.findall("link")}
    for link in links.values():
        if link.find("inertial") is None:  # Gazebo lumps such frames away; PyBullet would make them 1 kg
            _token_inertial(link)
    for gz in robot.findall("gazebo"):
        target = links.get(gz.get("reference"))
        mu = gz.findtext("mu1")
        if target is not None and mu and target.find("contact") is None:
            ET.SubElement(ET.SubElement(target, "contact"), "lateral_friction", value=mu.strip())
    base = ET.Element("link", name=BASE)
    _token_inertial(base)
    joint = ET.Element("joint", name=f"{BASE}_joint", type="fixed")
    ET.SubElement(joint, "parent", link=BASE)
    ET.SubElement(joint, "child", link=root)
    p = root_in_base
    ET.SubElement(joint, "origin", xyz=" ".join(map(_f, p.position)), rpy=" ".join(map(_f, (p.roll, p.pitch, p.yaw))))
    # PyBullet takes the first link as the base: put the new root first.
    robot.insert(0, joint)
    robot.insert(0, base)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def write_loadable_urdf(text: str, base_dir: Path, root: str, root_in_base: Pose3D,
                        package_path: list[Path] | None = None) -> Path:
    out = loadable_urdf_text(text, base_dir, root, root_in_base, package_path)
    key = hashlib.sha1(out.encode()).hexdigest()[:16]
    path = Path(tempfile.gettempdir()) / f"fleetnav_urdf_{key}.urdf"
    if not path.is_file():
        tmp = path.with_suffix(f".{key}.tmp")
        tmp.write_text(out, encoding="utf-8")
        tmp.replace(path)  # atomic: parallel workers may write the same file
    return path

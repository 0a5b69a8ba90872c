"""Reading a URDF: the chain of joints from the root link to a tip frame, checked, with Pinocchio.

Robot profiles of kind ``urdf`` are built from this chain (``core.kinematics.profile``) and the
CLIK solver (``core.kinematics.clik``) reduces its model to it.
"""
from __future__ import annotations

import math
import os
import threading
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Union

import pinocchio as pin

from core.kinematics.base import MAX_JOINTS, ProfileError

CONTINUOUS_LIMIT_RAD = 2.0 * math.pi  # a URDF "continuous" joint becomes revolute ±2π
DEFAULT_VELOCITY_RAD_S = 1.0  # a URDF joint with velocity="0" or none
DEFAULT_VELOCITY_M_S = 0.1
MAX_FRAMES_LISTED = 60  # an error listing valid frames names at most this many
_URDF_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


# --------------------------------------------------------------------------------------------
# Reading a URDF


@dataclass(frozen=True)
class ChainJoint:
    """A joint between the URDF's root and the tip, as the URDF gives it."""

    name: str
    joint_type: str  # "revolute" or "prismatic"
    lower: float  # rad or m
    upper: float  # rad or m
    max_velocity: float  # rad/s or m/s (a default when the URDF gives none)


@dataclass(frozen=True, eq=False)
class UrdfChain:
    """A URDF read and checked: the full model, the tip frame and the joints leading to it."""

    path: str
    robot_name: str
    tip: str
    joints: tuple[ChainJoint, ...]
    frames: tuple[str, ...]  # every frame name (valid tips), in model order
    model: object  # the full pinocchio Model (read-only)
    chain_joint_ids: tuple[int, ...]  # joint ids of ``joints`` in ``model``


_CACHE: dict[tuple, UrdfChain] = {}
_CACHE_LOCK = threading.Lock()


def _urdf_error(path: Path, message: str) -> ProfileError:
    return ProfileError(f"{path}: {message}")


def _prepare_urdf_xml(path: Path) -> tuple[str, str]:
    """Read and check the URDF's XML; returns (robot name, XML text for Pinocchio).

    Checks what urdfdom would only report on stderr (missing links, joints without limits) so
    the user gets one clear line, and turns "continuous" joints into revolute ±2π ones (deskarm
    commands every joint within finite limits).
    """
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise _urdf_error(path, "no such file — check the path") from None
    except IsADirectoryError:
        raise _urdf_error(path, "is a folder, expected a .urdf file") from None
    except OSError as exc:
        raise _urdf_error(path, f"cannot read ({exc.strerror or exc})") from None
    if b"xacro:" in raw:
        raise _urdf_error(path, "is a xacro file — expand it first (xacro arm.urdf.xacro > arm.urdf)")
    try:
        root = ET.fromstring(raw)
    except ET.ParseError as exc:
        raise _urdf_error(path, f"not valid XML ({exc})") from None
    if root.tag != "robot":
        raise _urdf_error(path, f"the root element is <{root.tag}>, expected <robot> — is this a URDF file?")
    links = {link.get("name") for link in root.findall("link")}
    if not links:
        raise _urdf_error(path, "has no <link> elements")
    for joint in root.findall("joint"):
        name = joint.get("name") or "?"
        jtype = joint.get("type")
        if jtype not in _URDF_JOINT_TYPES:
            raise _urdf_error(path, f"joint {name!r} has type {jtype!r}; expected one of {', '.join(_URDF_JOINT_TYPES)}")
        for role in ("parent", "child"):
            el = joint.find(role)
            link = el.get("link") if el is not None else None
            if link is None:
                raise _urdf_error(path, f"joint {name!r} has no <{role} link=...>")
            if link not in links:
                raise _urdf_error(path, f"joint {name!r} names {role} link {link!r}, which is not defined")
        limit = joint.find("limit")
        if jtype == "continuous":
            joint.set("type", "revolute")
            if limit is None:
                limit = ET.SubElement(joint, "limit", {"effort": "0", "velocity": "0"})
            limit.set("lower", repr(-CONTINUOUS_LIMIT_RAD))
            limit.set("upper", repr(CONTINUOUS_LIMIT_RAD))
        elif jtype in ("revolute", "prismatic"):
            if limit is None or limit.get("lower") is None or limit.get("upper") is None:
                raise _urdf_error(path, f"joint {name!r} ({jtype}) needs <limit lower=... upper=...>")
            try:
                lo, hi = float(limit.get("lower")), float(limit.get("upper"))
            except ValueError:
                raise _urdf_error(path, f"joint {name!r}: limit lower/upper must be numbers") from None
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise _urdf_error(path, f"joint {name!r}: limit lower = {lo:g} must be below upper = {hi:g}")
    return root.get("name") or path.stem, ET.tostring(root, encoding="unicode")


def _joint_type(model, jid: int, path: Path) -> str:
    short = model.joints[jid].shortname()
    if model.joints[jid].nq != 1 or model.joints[jid].nv != 1:
        raise _urdf_error(
            path,
            f"joint {model.names[jid]!r} ({short}) has {model.joints[jid].nq} coordinates; deskarm's"
            " IK drives revolute and prismatic joints only — pick a tip before it with --tip",
        )
    if short.startswith("JointModelP"):
        return "prismatic"
    if short.startswith("JointModelR"):
        return "revolute"
    raise _urdf_error(path, f"joint {model.names[jid]!r} is a {short}; expected revolute or prismatic")


def frame_names(model) -> tuple[str, ...]:
    out = []
    for f in model.frames:
        if f.name != "universe" and f.name not in out:
            out.append(f.name)
    return tuple(out)


def _default_tip(model) -> str:
    """The body frame deepest in the tree (most joints above it); the last one on ties."""
    best, best_depth = None, -1
    for f in model.frames:
        if f.type != pin.FrameType.BODY:
            continue
        depth = len(model.supports[f.parentJoint])
        if depth >= best_depth:
            best, best_depth = f.name, depth
    return best or model.frames[-1].name


def read_urdf_chain(path: Union[str, os.PathLike], tip: Optional[str] = None) -> UrdfChain:
    """Read a URDF, find ``tip`` (default: the deepest link) and the joints from the root to it.

    Raises ProfileError naming the file for an unreadable or malformed URDF, and naming the
    frame (with the list of valid frames) for an unknown tip. Results are cached per file
    version, so a profile loader and its solver share one model.
    """
    path = Path(path).expanduser().resolve()
    try:
        st = path.stat()
        key = (str(path), st.st_mtime_ns, st.st_size, tip)
    except OSError:
        key = None
    if key is not None:
        with _CACHE_LOCK:
            hit = _CACHE.get(key)
        if hit is not None:
            return hit
    robot_name, xml = _prepare_urdf_xml(path)
    try:
        model = pin.buildModelFromXML(xml)
    except Exception as exc:  # pinocchio raises ValueError/RuntimeError with urdfdom's reason on stderr
        raise _urdf_error(path, f"Pinocchio could not build a model from it ({exc})") from None
    frames = frame_names(model)
    tip_name = tip if tip is not None else _default_tip(model)
    if not model.existFrame(tip_name):  # getFrameId would return len(frames) without raising
        listed = ", ".join(frames[:MAX_FRAMES_LISTED]) + (" …" if len(frames) > MAX_FRAMES_LISTED else "")
        raise _urdf_error(path, f"no frame {tip_name!r} for --tip; valid frames: {listed}")
    fid = model.getFrameId(tip_name)
    chain_ids = tuple(int(j) for j in model.supports[model.frames[fid].parentJoint] if j != 0)
    if not chain_ids:
        raise _urdf_error(path, f"frame {tip_name!r} does not move: no joint lies between the root and it")
    if len(chain_ids) > MAX_JOINTS:
        raise _urdf_error(path, f"{len(chain_ids)} joints lead to {tip_name!r}; deskarm handles at most {MAX_JOINTS}")
    joints = []
    for jid in chain_ids:
        jtype = _joint_type(model, jid, path)
        iq, iv = model.joints[jid].idx_q, model.joints[jid].idx_v
        vel = float(model.velocityLimit[iv])
        if not (math.isfinite(vel) and vel > 0.0):
            vel = DEFAULT_VELOCITY_M_S if jtype == "prismatic" else DEFAULT_VELOCITY_RAD_S
        joints.append(ChainJoint(
            name=model.names[jid], joint_type=jtype, lower=float(model.lowerPositionLimit[iq]),
            upper=float(model.upperPositionLimit[iq]), max_velocity=min(vel, 100.0),
        ))
    chain = UrdfChain(
        path=str(path), robot_name=robot_name, tip=tip_name, joints=tuple(joints), frames=frames,
        model=model, chain_joint_ids=chain_ids,
    )
    if key is not None:
        with _CACHE_LOCK:
            _CACHE[key] = chain
    return chain

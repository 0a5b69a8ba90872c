"""Reading a URDF: the chain of joints from the root link to a tip frame, checked, with Pinocchio.

Robot profiles of kind ``urdf`` are built from this chain (``core.kinematics.profile``) and the
CLIK solver (``core.kinematics.clik``) reduces its model to it.

Mimic joints (``<mimic joint="X" multiplier="m" offset="o"/>``: a gripper's second finger, a
linkage) are not variables: Pinocchio builds them natively (``mimic=True``) with the value
``q = m·q_X + o``, so a chain through one has one variable fewer and the solver can never move
it on its own. The mimicked joint's limits are narrowed so that the mimic stays inside its
own limits too. A mimic on the tip's chain whose mimicked joint is not on that chain (its value
would move the tip without being a variable), or that Pinocchio cannot build, is refused with a
ProfileError; mimics off the chain are locked with the other joints off the chain.
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


@dataclass(frozen=True)
class MimicJoint:
    """A URDF joint whose value follows another one's: ``q = multiplier · q_primary + offset``."""

    name: str
    primary: str  # the mimicked joint
    multiplier: float
    offset: float  # rad or m
    joint_type: str  # "revolute" or "prismatic" (the mimic's own type)
    lower: float  # the mimic's own limits, rad or m
    upper: float

    def value(self, q_primary: float) -> float:
        """The mimic's value (rad or m) for the mimicked joint's value."""
        return self.multiplier * q_primary + self.offset


@dataclass(frozen=True, eq=False)
class UrdfChain:
    """A URDF read and checked: the full model, the tip frame and the joints leading to it."""

    path: str
    robot_name: str
    tip: str
    joints: tuple[ChainJoint, ...]  # the variables: mimic joints are not among them
    frames: tuple[str, ...]  # every frame name (valid tips), in model order
    model: object  # the full pinocchio Model (read-only), mimic joints built natively
    chain_joint_ids: tuple[int, ...]  # joint ids of ``joints`` in ``model``
    mimics: tuple[MimicJoint, ...] = ()  # mimic joints between the root and the tip
    mimic_joint_ids: tuple[int, ...] = ()  # their joint ids in ``model``


_CACHE: dict[tuple, UrdfChain] = {}
_CACHE_LOCK = threading.Lock()


def _urdf_error(path: Path, message: str) -> ProfileError:
    return ProfileError(f"{path}: {message}")


def _prepare_urdf_xml(path: Path) -> tuple[str, str, dict[str, MimicJoint]]:
    """Read and check the URDF's XML; returns (robot name, XML text for Pinocchio, mimic joints
    by name).

    Checks what urdfdom would only report on stderr (missing links, joints without limits) so
    the user gets one clear line, and turns "continuous" joints into revolute ±2π ones (deskarm
    commands every joint within finite limits). ``<mimic>`` tags are checked here too, because
    Pinocchio's own errors about them name neither the joint nor the cause.
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
    mimics = _read_mimics(path, root)
    return root.get("name") or path.stem, ET.tostring(root, encoding="unicode"), mimics


def _read_mimics(path: Path, root) -> dict[str, MimicJoint]:
    """The ``<mimic>`` joints of a prepared URDF tree (continuous joints already revolute), checked."""
    joints = {j.get("name"): j for j in root.findall("joint")}
    parent_joint = {j.find("child").get("link"): j.get("name") for j in root.findall("joint")}
    out: dict[str, MimicJoint] = {}
    for name, joint in joints.items():
        tag = joint.find("mimic")
        if tag is None:
            continue
        jtype = joint.get("type")
        if jtype == "fixed":  # nothing to derive; urdfdom ignores it too
            joint.remove(tag)
            continue
        if jtype not in ("revolute", "prismatic"):
            raise _urdf_error(path, f"joint {name!r} ({jtype}) has a <mimic>; only revolute, continuous"
                                    " and prismatic joints can mimic another joint")
        primary = tag.get("joint")
        if not primary:
            raise _urdf_error(path, f"joint {name!r}: <mimic> needs joint=\"NAME\" (the joint it follows)")
        if primary == name:
            raise _urdf_error(path, f"joint {name!r} mimics itself; name another joint in <mimic joint=...>")
        if primary not in joints:
            raise _urdf_error(path, f"joint {name!r} mimics {primary!r}, which is not defined")
        ptype = joints[primary].get("type")
        if ptype not in ("revolute", "prismatic"):
            raise _urdf_error(path, f"joint {name!r} mimics {primary!r}, a {ptype} joint; a mimicked joint must"
                                    " be revolute, continuous or prismatic")
        if joints[primary].find("mimic") is not None:
            raise _urdf_error(path, f"joint {name!r} mimics {primary!r}, which itself mimics"
                                    f" {joints[primary].find('mimic').get('joint')!r}: make {name!r} mimic that"
                                    " joint directly (multipliers multiply, offsets add up)")
        # Pinocchio needs the mimicked joint built first: not below the mimic on one branch
        link, seen = joints[primary].find("parent").get("link"), set()
        while link in parent_joint and link not in seen:
            seen.add(link)
            above = parent_joint[link]
            if above == name:
                raise _urdf_error(path, f"joint {name!r} mimics {primary!r}, which lies after it on the same"
                                        " chain; only a joint before its mimic can be mimicked here")
            link = joints[above].find("parent").get("link")
        values = {}
        for key, default in (("multiplier", 1.0), ("offset", 0.0)):
            try:
                values[key] = float(tag.get(key, default))
            except ValueError:
                values[key] = math.nan
            if not math.isfinite(values[key]):
                raise _urdf_error(path, f"joint {name!r}: <mimic {key}={tag.get(key)!r}> must be a finite number")
        limit = joint.find("limit")
        out[name] = MimicJoint(
            name=name, primary=primary, multiplier=values["multiplier"], offset=values["offset"],
            joint_type=jtype, lower=float(limit.get("lower")), upper=float(limit.get("upper")),
        )
    return out


def _mimic_limits(path: Path, lower: float, upper: float, name: str, mimics) -> tuple[float, float]:
    """``name``'s limits narrowed so that every joint mimicking it stays within its own limits."""
    for mj in mimics:
        if mj.primary != name:
            continue
        m, o = mj.multiplier, mj.offset
        if m == 0.0:
            if not mj.lower <= o <= mj.upper:
                raise _urdf_error(path, f"joint {mj.name!r} mimics {name!r} with multiplier 0: its value"
                                        f" {o:g} (the offset) is outside its limits {mj.lower:g}…{mj.upper:g}")
            continue
        a, b = (mj.lower - o) / m, (mj.upper - o) / m
        lower, upper = max(lower, min(a, b)), min(upper, max(a, b))
        if not lower < upper:
            raise _urdf_error(path, f"joint {mj.name!r} mimics {name!r} (q = {m:g}·q + {o:g}) but no value of"
                                    f" {name!r} within its limits keeps {mj.name!r} within {mj.lower:g}…{mj.upper:g}")
    return lower, upper


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


def _chain_problem(model, fid: int, mimic_pairs: dict, mimics: dict, native: bool) -> str:
    """Why the frame ``fid`` cannot be a tip because of a mimic joint on its chain, or ""."""
    supports = [int(j) for j in model.supports[model.frames[fid].parentJoint] if j != 0]
    for jid in supports:
        if model.names[jid] not in mimics:
            continue
        if not native or mimic_pairs.get(jid) not in supports:
            return "mimic"
    return ""


def _default_tip(model, mimic_pairs: dict, mimics: dict, native: bool) -> str:
    """The body frame deepest in the tree (most joints above it; the last one on ties) among the
    tips ``read_urdf_chain`` accepts. A chain through a joint that other joints mimic (the one
    motor of a gripper's fingers) ends at a finger, not at the arm's tool: frames before such a
    joint come first, and a finger is the default only when nothing else moves."""
    mimicked = {model.names[j] for j in mimic_pairs.values()} | {mj.primary for mj in mimics.values()}
    best: dict[bool, tuple[int, str]] = {}
    for fid, f in enumerate(model.frames):
        if f.type != pin.FrameType.BODY or _chain_problem(model, fid, mimic_pairs, mimics, native):
            continue
        joints = [int(j) for j in model.supports[f.parentJoint] if j != 0]
        if not joints:
            continue
        through_gripper = any(model.names[j] in mimicked for j in joints)
        if len(joints) >= best.get(through_gripper, (-1, ""))[0]:
            best[through_gripper] = (len(joints), f.name)
    for through_gripper in (False, True):
        if through_gripper in best:
            return best[through_gripper][1]
    # nothing acceptable moves: the deepest frame, whose chain gives the reason
    deepest, depth = model.frames[-1].name, -1
    for f in model.frames:
        if f.type == pin.FrameType.BODY and len(model.supports[f.parentJoint]) >= depth:
            deepest, depth = f.name, len(model.supports[f.parentJoint])
    return deepest


def read_urdf_chain(path: Union[str, os.PathLike], tip: Optional[str] = None) -> UrdfChain:
    """Read a URDF, find ``tip`` and the joints from the root to it.

    The default tip is the deepest link it accepts (``_default_tip``: the arm's tool before a
    gripper's fingers, never a frame whose chain holds a mimic without the joint it follows).

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
    robot_name, xml, mimics = _prepare_urdf_xml(path)
    mimic_problem = ""  # why Pinocchio could not build the mimic joints natively, if it could not
    try:
        model = pin.buildModelFromXML(xml, mimic=bool(mimics))
    except Exception as exc:  # pinocchio raises ValueError/RuntimeError with urdfdom's reason on stderr
        if not mimics:
            raise _urdf_error(path, f"Pinocchio could not build a model from it ({exc})") from None
        # mimic joints on other branches can still be out of the order Pinocchio needs: such a
        # URDF stays usable as long as no mimic lies on the tip's chain (checked below)
        mimic_problem = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        try:
            model = pin.buildModelFromXML(xml)
        except Exception as exc2:
            raise _urdf_error(path, f"Pinocchio could not build a model from it ({exc2})") from None
    native = bool(mimics) and not mimic_problem
    # mimic joint id -> the id of the joint it mimics
    mimic_pairs = (dict(zip((int(j) for j in model.mimicking_joints), (int(j) for j in model.mimicked_joints)))
                   if native else {})
    frames = frame_names(model)
    tip_name = tip if tip is not None else _default_tip(model, mimic_pairs, mimics, native)
    if not model.existFrame(tip_name):  # getFrameId would return len(frames) without raising
        listed = ", ".join(frames[:MAX_FRAMES_LISTED]) + (" …" if len(frames) > MAX_FRAMES_LISTED else "")
        raise _urdf_error(path, f"no frame {tip_name!r} for --tip; valid frames: {listed}")
    fid = model.getFrameId(tip_name)
    supports = tuple(int(j) for j in model.supports[model.frames[fid].parentJoint] if j != 0)
    chain_mimic_ids = tuple(j for j in supports if j in mimic_pairs)
    chain_ids = tuple(j for j in supports if j not in mimic_pairs)
    for jid in supports:
        mj = mimics.get(model.names[jid])
        if mj is None:
            continue
        if not native:
            raise _urdf_error(path, f"joint {mj.name!r} on the chain to {tip_name!r} mimics {mj.primary!r}, and"
                                    f" Pinocchio could not build that mimic ({mimic_problem}); pick a tip before"
                                    " it with --tip, or remove the <mimic>")
        if mimic_pairs[jid] not in chain_ids:
            raise _urdf_error(path, f"joint {mj.name!r} on the chain to {tip_name!r} mimics {mj.primary!r}, which"
                                    " is not on that chain: its value would move the tip without being a variable;"
                                    " pick a tip whose chain holds both, or one before it, with --tip")
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
        lower, upper = _mimic_limits(path, float(model.lowerPositionLimit[iq]), float(model.upperPositionLimit[iq]),
                                     model.names[jid], mimics.values())
        joints.append(ChainJoint(
            name=model.names[jid], joint_type=jtype, lower=lower, upper=upper, max_velocity=min(vel, 100.0),
        ))
    chain = UrdfChain(
        path=str(path), robot_name=robot_name, tip=tip_name, joints=tuple(joints), frames=frames,
        model=model, chain_joint_ids=chain_ids,
        mimics=tuple(mimics[model.names[j]] for j in chain_mimic_ids), mimic_joint_ids=chain_mimic_ids,
    )
    if key is not None:
        with _CACHE_LOCK:
            _CACHE[key] = chain
    return chain

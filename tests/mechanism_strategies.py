"""Hypothesis strategies that generate random mechanisms as model files (URDF + <clearance_pin>).

A random mechanism is a tree of 2..8 moving bodies on the ground, each on a tree joint of a random
kind (spherical, cylindrical, revolute with axial play, prismatic, planar revolute, ideal revolute
or prismatic, rigid, free), closed by 0..2 loop joints between random bodies at a random point,
with clearances from 1e-6 to 1e-3 m, lengths from 1 cm to 1 m, random forces and torques, and
sometimes gravity. Every body is placed in the world first; the URDF origins follow, and the two
frames of every loop joint are placed at the same world point with the same (world) orientation,
so the loops are closed at the nominal configuration by construction.

``MechanismSpec.urdf()`` writes the model file text; the spec's ``repr`` is a complete reproducer.
"""

from __future__ import annotations

import tomllib
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from hypothesis import strategies as st

# Hypothesis (>= 6.131) draws 5% of its numbers from the literal constants of every non-test
# module found in sys.modules at draw time. That pool grows as earlier tests import more of
# clearance_pin and the benchmark and validation scripts, so a derandomized test drew other examples
# in the full suite than alone (and then shrank a failure for minutes), and the stability benchmark
# drew other mechanisms at every commit. Keep the pool empty: the examples depend on the seed
# only. (Private API, hence the guard.)
try:
    from hypothesis.internal.conjecture import providers as _providers
    from hypothesis.internal.constants_ast import Constants as _Constants
except ImportError:  # pragma: no cover - other Hypothesis versions
    pass
else:
    if hasattr(_providers, "_get_local_constants"):
        _providers._get_local_constants = _Constants

TREE_KINDS = (
    "spherical",
    "cylindrical",
    "revolute",
    "prismatic",
    "planar_revolute",
    "ideal_revolute",
    "ideal_prismatic",
    "rigid",
    "free",
)
LOOP_KINDS = (
    "spherical",
    "cylindrical",
    "revolute",
    "prismatic",
    "planar_revolute",
    "rigid",
    "ideal_revolute",
)
URDF_TYPE = {
    "spherical": "floating",
    "cylindrical": "floating",
    "rigid": "floating",
    "free": "floating",
    "revolute": "revolute",
    "planar_revolute": "revolute",
    "ideal_revolute": "revolute",
    "prismatic": "prismatic",
    "ideal_prismatic": "prismatic",
}


@dataclass(frozen=True)
class JointSpec:
    """A joint: kind, axis (world), radial play c [m], length L [m], axial play [m], prismatic
    width/height [m], driven, nominal value q [rad or m]."""

    kind: str
    axis: tuple
    radial: float
    length: float = 0.0
    axial: float = 0.0
    width: float = 0.0
    height: float = 0.0
    driven: bool = False
    q: float = 0.0

    def attributes(self) -> str:
        """The clearance attributes of the joint in the <clearance_pin> block."""
        kind = self.kind
        if kind.startswith("ideal_"):
            return ""
        if kind in ("rigid", "free"):
            return f'type="{kind}"'
        text = f'type="{kind}" radial_clearance="{self.radial!r}"'
        if kind in ("cylindrical", "revolute", "prismatic"):
            text += f' length="{self.length!r}"'
        if kind == "revolute":
            text += f' axial_clearance="{self.axial!r}"'
        if kind == "prismatic":
            text += f' width="{self.width!r}" height="{self.height!r}"'
        return text


@dataclass(frozen=True)
class BodySpec:
    """A moving body: its parent (0 = ground), world position [m] and orientation (rpy) at the
    nominal configuration, its tree joint, and its mass [kg] (0: no inertial)."""

    parent: int
    position: tuple
    rpy: tuple
    joint: JointSpec
    mass: float = 0.0


@dataclass(frozen=True)
class LoopSpec:
    """A loop joint between bodies a and b at a world point (frames oriented as the world)."""

    body_a: int
    body_b: int
    point: tuple
    joint: JointSpec


@dataclass(frozen=True)
class LoadSpec:
    """A force [N] at a point [m] of a body (its link frame), or a torque [N m]; world axes."""

    body: int
    value: tuple
    point: tuple | None = None  # None: a torque


@dataclass(frozen=True)
class MechanismSpec:
    """A random mechanism; ``urdf()`` gives its model file."""

    bodies: tuple
    loops: tuple
    loads: tuple
    gravity: bool = False

    def world_placements(self) -> list[pin.SE3]:
        """Nominal world placement of every body frame (index 0: ground)."""
        out = [pin.SE3.Identity()]
        for body in self.bodies:
            rotation = pin.rpy.rpyToMatrix(*body.rpy)
            out.append(pin.SE3(rotation, np.array(body.position, dtype=float)))
        return out

    def urdf(self) -> str:
        """The model file text."""
        placements = self.world_placements()
        links, joints, block = ['  <link name="b0"/>'], [], []
        for index, body in enumerate(self.bodies, start=1):
            inertial = ""
            if body.mass > 0.0:
                inertial = (
                    f'<inertial><mass value="{body.mass!r}"/><origin xyz="0.01 0.02 0.03"/>'
                    '<inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/>'
                    "</inertial>"
                )
            links.append(f'  <link name="b{index}">{inertial}</link>')
            joint = body.joint
            urdf_type = URDF_TYPE[joint.kind]
            child = placements[index]
            parent = placements[body.parent]
            axis_world = np.array(joint.axis, dtype=float)
            axis_child = child.rotation.T @ axis_world
            motion = pin.SE3.Identity()
            if urdf_type == "revolute":
                motion = pin.SE3(pin.exp3(axis_child * joint.q), np.zeros(3))
            elif urdf_type == "prismatic":
                motion = pin.SE3(np.eye(3), axis_child * joint.q)
            origin = parent.inverse() * child * motion.inverse()
            text = (
                f'  <joint name="j{index}" type="{urdf_type}">'
                f'<parent link="b{body.parent}"/><child link="b{index}"/>'
                f'<origin xyz="{_xyz(origin.translation)}" '
                f'rpy="{_xyz(pin.rpy.matrixToRpy(origin.rotation))}"/>'
            )
            if urdf_type != "floating":
                text += f'<axis xyz="{_xyz(axis_child)}"/>'
            if urdf_type in ("revolute", "prismatic"):
                text += '<limit lower="-10" upper="10" effort="1" velocity="1"/>'
            joints.append(text + "</joint>")
            attributes = joint.attributes()
            extra = ""
            if urdf_type == "floating":
                if joint.kind not in ("rigid", "free"):
                    extra = f' axis="{_xyz(axis_child)}"'
            else:
                if joint.driven:
                    extra += ' driven="true"'
                if joint.q != 0.0:
                    extra += f' q="{joint.q!r}"'
            if attributes or extra:
                block.append(f'    <joint name="j{index}" {attributes}{extra}/>')
        for k, loop in enumerate(self.loops):
            point = np.array(loop.point, dtype=float)
            for side, body in (("a", loop.body_a), ("b", loop.body_b)):
                local = placements[body].inverse() * pin.SE3(np.eye(3), point)
                links.append(f'  <link name="loop{k}_{side}"/>')
                joints.append(
                    f'  <joint name="loop{k}_{side}_mount" type="fixed">'
                    f'<parent link="b{body}"/><child link="loop{k}_{side}"/>'
                    f'<origin xyz="{_xyz(local.translation)}" '
                    f'rpy="{_xyz(pin.rpy.matrixToRpy(local.rotation))}"/></joint>'
                )
            joint = loop.joint
            attributes = joint.attributes()
            if joint.kind == "ideal_revolute":
                attributes = f'type="revolute" radial_clearance="0.0" length="{joint.length!r}"'
            block.append(
                f'    <loop_joint name="L{k}" frame_a="loop{k}_a" frame_b="loop{k}_b" '
                f'{attributes} axis="{_xyz(joint.axis)}"/>'
            )
        for load in self.loads:
            if load.point is None:
                block.append(f'    <torque link="b{load.body}" value="{_xyz(load.value)}"/>')
            else:
                block.append(
                    f'    <force link="b{load.body}" point="{_xyz(load.point)}" '
                    f'value="{_xyz(load.value)}"/>'
                )
        if self.gravity:
            block.append('    <gravity value="0 0 -9.81" enabled="true"/>')
        return "\n".join(
            [
                '<?xml version="1.0"?>',
                '<robot name="random">',
                *links,
                *joints,
                "  <clearance_pin>",
                *block,
                "  </clearance_pin>",
                "</robot>",
                "",
            ]
        )


def _xyz(vector) -> str:
    return " ".join(repr(float(v)) for v in vector)


# -- strategies -----------------------------------------------------------------------------------
def log_uniform(low: float, high: float):
    """Floats spread evenly in log scale between low and high."""
    return st.floats(np.log10(low), np.log10(high)).map(lambda e: float(10.0**e))


unit_vectors = st.one_of(
    st.sampled_from([(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)]),
    st.tuples(*[st.floats(-1.0, 1.0)] * 3)
    .filter(lambda v: np.linalg.norm(v) > 0.2)
    .map(lambda v: tuple(float(a) for a in np.asarray(v) / np.linalg.norm(v))),
)


@st.composite
def joints(draw, kinds=TREE_KINDS, clearance=(1e-6, 1e-3), lengths=(0.005, 0.2)):
    """A joint of one of ``kinds`` with random plays and dimensions."""
    kind = draw(st.sampled_from(kinds))
    radial = draw(
        st.one_of(log_uniform(*clearance), st.just(0.0))
        if kind != "ideal_revolute"
        else st.just(0.0)
    )
    length = draw(log_uniform(*lengths))
    axial = draw(st.one_of(log_uniform(*clearance), st.just(0.0)))
    width = draw(st.sampled_from([0.0, 0.5 * length]))
    height = draw(st.sampled_from([0.0, 0.3 * length]))
    driven = draw(st.booleans()) if URDF_TYPE[kind] != "floating" else False
    q = draw(st.sampled_from([0.0, 0.3, -1.2])) if URDF_TYPE[kind] != "floating" else 0.0
    if kind in ("prismatic", "ideal_prismatic"):
        q = 0.1 * q
    return JointSpec(kind, draw(unit_vectors), radial, length, axial, width, height, driven, q)


@st.composite
def mechanisms(
    draw,
    min_bodies: int = 2,
    max_bodies: int = 8,
    max_loops: int = 2,
    size=(0.01, 1.0),
    clearance=(1e-6, 1e-3),
):
    """A random tree with loops, loads and sometimes gravity (see the module docstring)."""
    count = draw(st.integers(min_bodies, max_bodies))
    extent = draw(log_uniform(*size))
    coordinate = st.floats(-1.0, 1.0).map(lambda v: v * extent)
    angle = st.floats(-np.pi, np.pi)
    gravity = draw(st.booleans()) and draw(st.booleans())
    bodies = []
    for index in range(1, count + 1):
        parent = draw(st.integers(0, index - 1))
        bodies.append(
            BodySpec(
                parent,
                tuple(draw(st.tuples(coordinate, coordinate, coordinate))),
                tuple(draw(st.tuples(angle, angle, angle))),
                draw(joints(clearance=clearance)),
                draw(st.sampled_from([0.0, 0.5])) if gravity else 0.0,
            )
        )
    loops = []
    for _ in range(draw(st.integers(0, max_loops))):
        a = draw(st.integers(0, count - 1))
        b = draw(st.integers(a + 1, count))
        point = draw(st.tuples(coordinate, coordinate, coordinate))
        loops.append(LoopSpec(a, b, tuple(point), draw(joints(LOOP_KINDS, clearance=clearance))))
    force = st.floats(-100.0, 100.0)
    loads = []
    for _ in range(draw(st.integers(0 if gravity else 1, 3))):
        body = draw(st.integers(1, count))
        if draw(st.booleans()):
            loads.append(
                LoadSpec(
                    body,
                    draw(st.tuples(force, force, force)),
                    tuple(draw(st.tuples(coordinate, coordinate, coordinate))),
                )
            )
        else:
            loads.append(
                LoadSpec(body, tuple(v * extent for v in draw(st.tuples(force, force, force))))
            )
    return MechanismSpec(tuple(bodies), tuple(loops), tuple(loads), gravity)


# -- fixed model files with known answers (scale and degeneracy studies) --------------------------
def ball_text(clearance: float, centre=(0.3, 0.1, 0.2)) -> str:
    """A part on one spherical joint (clearance frame = world axes) centred at ``centre`` [m]."""
    return f"""<?xml version="1.0"?>
<robot name="ball">
  <link name="ground"/><link name="part"/>
  <joint name="ball" type="floating"><parent link="ground"/><child link="part"/>
    <origin xyz="{_xyz(centre)}"/></joint>
  <clearance_pin>
    <joint name="ball" type="spherical" radial_clearance="{clearance!r}"/>
  </clearance_pin>
</robot>
"""


def journal_text(clearance: float, length: float, centre=(0.1, 0.0, 0.0)) -> str:
    """A shaft in one cylindrical joint of length ``length`` along x, centred at ``centre``."""
    return f"""<?xml version="1.0"?>
<robot name="journal">
  <link name="ground"/><link name="shaft"/>
  <joint name="bore" type="floating"><parent link="ground"/><child link="shaft"/>
    <origin xyz="{_xyz(centre)}"/></joint>
  <clearance_pin>
    <joint name="bore" type="cylindrical" radial_clearance="{clearance!r}" length="{length!r}"
           axis="1 0 0"/>
  </clearance_pin>
</robot>
"""


def two_joint_shaft_text(
    first: tuple,
    second: tuple,
    centre_b,
    force=(0.0, 0.0, 0.0),
    point=(0.0, 0.0, 0.0),
    torque=(0.0, 0.0, 0.0),
) -> str:
    """A shaft on a tree joint at the origin and a loop joint at ``centre_b`` (both axes x).

    ``first`` / ``second`` are (kind, radial clearance [m], length [m]); the force [N] acts at the
    world ``point`` [m]; the torque [N m] is in world axes.
    """

    def attributes(kind, radial, length):
        text = f'type="{kind}" radial_clearance="{radial!r}" axis="1 0 0"'
        return text + (f' length="{length!r}"' if length else "")

    return f"""<?xml version="1.0"?>
<robot name="shaft">
  <link name="ground"/><link name="shaft"/><link name="ground_I2"/><link name="shaft_I2"/>
  <joint name="I1" type="floating"><parent link="ground"/><child link="shaft"/></joint>
  <joint name="ground_I2_mount" type="fixed"><parent link="ground"/><child link="ground_I2"/>
    <origin xyz="{_xyz(centre_b)}"/></joint>
  <joint name="shaft_I2_mount" type="fixed"><parent link="shaft"/><child link="shaft_I2"/>
    <origin xyz="{_xyz(centre_b)}"/></joint>
  <clearance_pin>
    <joint name="I1" {attributes(*first)}/>
    <loop_joint name="I2" frame_a="ground_I2" frame_b="shaft_I2" {attributes(*second)}/>
    <force link="shaft" point="{_xyz(point)}" value="{_xyz(force)}"/>
    <torque link="shaft" value="{_xyz(torque)}"/>
  </clearance_pin>
</robot>
"""


def four_bar_text(
    delta: float,
    play: float = 5e-5,
    a: float = 0.06,
    b: float = 0.15,
    c: float = 0.11,
    d: float = 0.2,
) -> str:
    """A four-bar (crank a, coupler b, rocker c, ground d, b + c = a + d) with its driven crank
    ``delta`` [rad] before the toggle position where coupler and rocker are stretched in line.

    The passive joint values are computed exactly, so no loop closing is needed; planar pins with
    radial play ``play`` [m] everywhere; a force on the coupler and a torque on the rocker.
    """
    theta = float(np.pi - delta)
    a_point = a * np.array([np.cos(theta), np.sin(theta)])
    o4 = np.array([d, 0.0])
    distance = float(np.linalg.norm(o4 - a_point))
    e = (o4 - a_point) / distance
    x = (b**2 - c**2 + distance**2) / (2.0 * distance)
    h = float(np.sqrt(max(b**2 - x**2, 0.0)))
    b_point = a_point + x * e + h * np.array([-e[1], e[0]])
    q2 = float(np.arctan2(*(b_point - a_point)[::-1]) - theta)
    q3 = float(np.arctan2(*(b_point - o4)[::-1]))
    limit = '<limit lower="-7" upper="7" effort="1" velocity="1"/>'
    return f"""<?xml version="1.0"?>
<robot name="four_bar_toggle">
  <link name="ground"/><link name="crank"/><link name="coupler"/><link name="rocker"/>
  <link name="coupler_B"/><link name="rocker_B"/>
  <joint name="crank_pivot" type="revolute"><parent link="ground"/><child link="crank"/>
    <axis xyz="0 0 1"/>{limit}</joint>
  <joint name="pin_A" type="revolute"><parent link="crank"/><child link="coupler"/>
    <origin xyz="{a!r} 0 0"/><axis xyz="0 0 1"/>{limit}</joint>
  <joint name="rocker_pivot" type="revolute"><parent link="ground"/><child link="rocker"/>
    <origin xyz="{d!r} 0 0"/><axis xyz="0 0 1"/>{limit}</joint>
  <joint name="coupler_B_mount" type="fixed"><parent link="coupler"/><child link="coupler_B"/>
    <origin xyz="{b!r} 0 0"/></joint>
  <joint name="rocker_B_mount" type="fixed"><parent link="rocker"/><child link="rocker_B"/>
    <origin xyz="{c!r} 0 0"/></joint>
  <clearance_pin>
    <joint name="crank_pivot" type="planar_revolute" radial_clearance="{play!r}" driven="true"
           q="{theta!r}"/>
    <joint name="pin_A" type="planar_revolute" radial_clearance="{play!r}" q="{q2!r}"/>
    <joint name="rocker_pivot" type="planar_revolute" radial_clearance="{play!r}" q="{q3!r}"/>
    <loop_joint name="pin_B" type="planar_revolute" frame_a="rocker_B" frame_b="coupler_B"
                radial_clearance="{play!r}" axis="0 0 1"/>
    <force link="coupler" point="{b / 2!r} 0 0" value="3 -40 0"/>
    <torque link="rocker" value="0 0 -2"/>
  </clearance_pin>
</robot>
"""


PAPER_CASES = Path(__file__).resolve().parent.parent / "validation" / "younes2013_cases.toml"


def paper_cases() -> list[dict]:
    """The cases of Younes, Dal Santo & Potiron, section 6 (validation/younes2013_cases.toml)."""
    return tomllib.loads(PAPER_CASES.read_text())["case"]


def paper_case_text(case: dict, ratio: float | None = None) -> str:
    """Model file of a paper case; with ``ratio``, every clearance is scaled so that the largest
    radial clearance is ``ratio`` times the distance between the two joint centres."""
    from clearance_pin.model.builders import JointSpec as ShaftJoint
    from clearance_pin.model.builders import shaft_urdf

    joints = case["joint"]
    factor = 1.0
    if ratio is not None:
        span = float(np.linalg.norm(np.subtract(joints[1]["center_m"], joints[0]["center_m"])))
        largest = max(0.5 * j["diametral_clearance_m"] for j in joints)
        factor = ratio * span / largest
    specs = [
        ShaftJoint(
            j["name"],
            j["kind"],
            tuple(j["center_m"]),
            factor * j["diametral_clearance_m"],
            j.get("length_m", 0.0),
            tuple(j.get("axis", (1.0, 0.0, 0.0))),
        )
        for j in joints
    ]
    load = case["load"]
    return shaft_urdf(
        specs[0],
        specs[1],
        load["point_m"],
        load["force_N"],
        load["torque_Nm"],
        name="case_" + case["id"].replace(".", "_").replace("=", "_"),
    )


LENGTH_ATTRIBUTES = (
    "radial_clearance",
    "diametral_clearance",
    "axial_clearance",
    "play_z",
    "length",
    "width",
    "height",
)


def scale_model_text(text: str, factor: float) -> str:
    """The same mechanism with every length multiplied by ``factor`` (1e3: metres to millimetres).

    Scaled: URDF origins, inertial origins, clearances and lengths, load points, torques (a torque
    is a force times a length). Kept: forces, angles, axes, gravity, nominal values ``q`` (the
    models scaled here have revolute joints only). Dropped: ``<dimension>`` (tolerances play no
    part in the equilibrium).
    """
    root = ET.fromstring(text)
    for origin in root.iter("origin"):
        if origin.get("xyz") is not None:
            origin.set("xyz", _xyz(factor * np.array(origin.get("xyz").split(), dtype=float)))
    block = root.find("clearance_pin")
    for dimension in block.findall("dimension") if block is not None else ():
        block.remove(dimension)  # ISO grades depend on the nominal size in SI: not scalable
    for element in block if block is not None else ():
        for attribute in LENGTH_ATTRIBUTES:
            if element.get(attribute) is not None:
                element.set(attribute, repr(factor * float(element.get(attribute))))
        if element.tag == "force" and element.get("point") is not None:
            element.set("point", _xyz(factor * np.array(element.get("point").split(), float)))
        if element.tag == "torque":
            element.set("value", _xyz(factor * np.array(element.get("value").split(), float)))
    return ET.tostring(root, encoding="unicode")

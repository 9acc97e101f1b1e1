r"""The mechanism's skeleton at an equilibrium: its geometry, nominal and settled, for the pictures.

A *skeleton* is what a sketch of a mechanism shows: each joint's centre (both sides of it: the
housing on the parent part and the journal, ball or block on the child part), each part as lines
between the points it carries (its joint centres, the frames of its loop joints, its output frames
and load points), the contact points of the joints with their forces, and the applied point forces.
Every point is known twice, in world coordinates [m]: at the nominal pose and at the settled pose.

A picture magnifies the displacement: a point nominally at :math:`p_0` that settles at :math:`p`
is drawn at :math:`p_0 + m (p - p_0)` (:func:`magnify`). Magnifying every point by the same factor
keeps the relative motion inside a joint magnified exactly :math:`m` times, so a journal centre in
contact lies on its play circle of radius :math:`m c` around the magnified housing centre.

A mechanism is *planar* (:meth:`Skeleton.plane`) when every rotational joint's axis is parallel to
one normal :math:`n`, every prismatic joint's axis lies in the plane normal to :math:`n`, no joint
is spherical or free, and the settled displacement has no component along :math:`n`: it is drawn
in that plane; another one is spatial and drawn in 3-D.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt

from ..equilibrium.poses import ClearanceFrames, clearance_frames
from ..equilibrium.result import Equilibrium
from ..errors import ArgumentError
from ..model.loads import Gravity, PointForce, Torque
from .style import nice_round

if TYPE_CHECKING:
    from ..mechanism import Mechanism

FloatArray = npt.NDArray[np.float64]

ROTATIONAL = ("planar_revolute", "revolute", "cylindrical")
SPATIAL_KINDS = ("spherical", "free")
DISPLACEMENT_FRACTION = 0.05  # the largest displacement drawn at about 5 % of the size
OUT_OF_PLANE = 1e-6  # out-of-plane share of the displacement still called planar
CIRCLE = np.linspace(0.0, 2.0 * np.pi, 73)  # angles of a drawn circle [rad]
COINCIDENT = 1e-9  # points of one part closer than this share of the size are one point


@dataclass(frozen=True)
class JointMark:
    """One joint (tree or loop) of the skeleton.

    Attributes:
        name: joint name.
        kind: clearance kind (:data:`clearance_pin.model.clearance.KINDS`).
        loop: a loop joint (joins two frames) rather than a tree joint.
        driven: the joint's own motion is held by its drive.
        parent_body, child_body: Pinocchio joint index of the housing's part and of the moving
            part (0: the ground).
        axes: world axes (3, 3) of the parent-side clearance frame at the nominal pose, column 0
            the joint axis.
        housing, housing_moved: origin of the parent-side clearance frame (the bore's, guide's or
            socket's centre), nominal and settled [m], (3,).
        journal, journal_moved: origin of the child-side clearance frame (the journal's, block's
            or ball's centre), nominal and settled [m], (3,).
        radial: radial play c [m] (prismatic: the play across the clearance frame's y).
        play_z: prismatic play across z [m] (others: ``radial``).
        axial: axial play [m] of a revolute joint.
        length: journal or block length L [m] (0 when the kind has none).
    """

    name: str
    kind: str
    loop: bool
    driven: bool
    parent_body: int
    child_body: int
    axes: FloatArray
    housing: FloatArray
    housing_moved: FloatArray
    journal: FloatArray
    journal_moved: FloatArray
    radial: float
    play_z: float
    axial: float
    length: float

    @property
    def axis(self) -> FloatArray:
        """The joint axis, world, unit (3,)."""
        return self.axes[:, 0]

    @property
    def has_play(self) -> bool:
        """Some of the joint's contact points have play."""
        return max(self.radial, self.play_z, self.axial) > 0.0


@dataclass(frozen=True)
class ContactMark:
    """One contact point of one joint.

    Attributes:
        label: ``joint:point``.
        joint: joint name.
        point, moved: the child part's contact point, nominal and settled, world [m], (3,).
        force: force of the housing on the child part at the point [N], world axes, (3,).
        active: the point touches.
        shape: ``"norm"`` (a ball or disc of play) or ``"abs"`` (a slab: one direction).
        directions: world directions (3, k) of the displacement components the play bounds.
        bound: the play bounding the point [m].
    """

    label: str
    joint: str
    point: FloatArray
    moved: FloatArray
    force: FloatArray
    active: bool
    shape: str
    directions: FloatArray
    bound: float


@dataclass(frozen=True)
class LoadMark:
    """An applied point force.

    Attributes:
        label: ``link@[x y z]`` (the point in the link frame [m]).
        point, moved: its application point, nominal and settled, world [m], (3,).
        force: the force [N], world axes, (3,).
    """

    label: str
    point: FloatArray
    moved: FloatArray
    force: FloatArray


@dataclass(frozen=True)
class OutputMark:
    """An output point (:attr:`Equilibrium.outputs`).

    Attributes:
        name: the output's name (a frame, or ``link@[x y z]``).
        point, moved: nominal and settled, world [m], (3,).
    """

    name: str
    point: FloatArray
    moved: FloatArray

    @property
    def displacement(self) -> float:
        """Length of its displacement [m]."""
        return float(np.linalg.norm(self.moved - self.point))


@dataclass(frozen=True)
class Skeleton:
    """The skeleton of a mechanism at one equilibrium (world coordinates [m]).

    Attributes:
        name: the mechanism's name.
        formulation: ``"linear"`` or ``"exact"``, of the equilibrium.
        points, moved: every point the parts carry, nominal and settled, (P, 3) [m].
        bodies: the part (Pinocchio joint index, 0 = ground) carrying each point, (P,).
        links: segments (i, j) between points of one part: each part's points joined by their
            shortest spanning tree (a straight part is one line through its points). A journal
            or block of length L adds its axis (its two ends) to its part, and the housing's
            axis of the same length to the housing's part.
        joints: every joint, tree joints first.
        contacts: every contact point (active or not).
        loads: the applied point forces.
        torques: links carrying an applied torque (not drawn: named in the picture).
        gravity: gravity is among the loads (not drawn: named in the picture).
        outputs: the output points of the equilibrium.
    """

    name: str
    formulation: str
    points: FloatArray
    moved: FloatArray
    bodies: npt.NDArray[np.int64]
    links: tuple[tuple[int, int], ...]
    joints: tuple[JointMark, ...]
    contacts: tuple[ContactMark, ...]
    loads: tuple[LoadMark, ...]
    torques: tuple[str, ...]
    gravity: bool
    outputs: tuple[OutputMark, ...]

    @property
    def active_contacts(self) -> tuple[ContactMark, ...]:
        """The contact points that touch."""
        return tuple(c for c in self.contacts if c.active)

    def size(self) -> float:
        """The mechanism's size [m]: the diagonal of the box around its nominal points (the
        largest journal or block length when the points coincide; 1 m when all is 0)."""
        extent = float(np.linalg.norm(np.ptp(self.points, axis=0))) if len(self.points) else 0.0
        return extent or max((j.length for j in self.joints), default=0.0) or 1.0

    def largest_displacement(self) -> float:
        """The largest settled displacement of a point, contact point or output [m]."""
        moves = [np.linalg.norm(self.moved - self.points, axis=1)]
        moves += [np.array([np.linalg.norm(c.moved - c.point) for c in self.contacts])]
        moves += [np.array([o.displacement for o in self.outputs])]
        return float(max((m.max(initial=0.0) for m in moves), default=0.0))

    def default_magnification(self, fraction: float = DISPLACEMENT_FRACTION) -> float:
        """A round magnification (1-2-5 series) drawing the largest displacement at about
        ``fraction`` of :meth:`size` (between 0.63 and 1.6 times it); 1 without displacement."""
        largest = self.largest_displacement()
        if largest <= 0.0:
            return 1.0
        return nice_round(fraction * self.size() / largest)

    def plane(self) -> FloatArray | None:
        """The unit normal (3,) of the mechanism's plane of motion, or None for a spatial one.

        Planar: no spherical or free joint; the axes of the rotational joints (planar revolute,
        revolute, cylindrical) parallel to one normal (from the nominal points' plane when there
        is no rotational joint); the prismatic joints' axes in that plane; and the settled
        displacement of every point within :data:`OUT_OF_PLANE` of the largest one in the plane.
        """
        normal: FloatArray | None = None
        for joint in self.joints:
            if joint.kind in SPATIAL_KINDS:
                return None
            if joint.kind in ROTATIONAL:
                if normal is None:
                    normal = joint.axis / np.linalg.norm(joint.axis)
                elif np.linalg.norm(np.cross(normal, joint.axis)) > 1e-9:
                    return None
        if normal is None:
            normal = _points_plane(self.points, self.size())
            if normal is None:
                return None
        for joint in self.joints:
            if joint.kind == "prismatic" and abs(float(normal @ joint.axis)) > 1e-9:
                return None
        moves = [self.moved - self.points]
        moves += [np.array([c.moved - c.point for c in self.contacts]).reshape(-1, 3)]
        moves += [np.array([o.moved - o.point for o in self.outputs]).reshape(-1, 3)]
        every = np.vstack(moves)
        largest = float(np.linalg.norm(every, axis=1).max(initial=0.0))
        if np.abs(every @ normal).max(initial=0.0) > OUT_OF_PLANE * largest:
            return None
        return normal


def magnify(nominal: FloatArray, moved: FloatArray, magnification: float) -> FloatArray:
    """Points drawn with their displacement magnified: ``nominal + m (moved - nominal)`` [m]."""
    return nominal + magnification * (moved - nominal)


def play_outlines(joint: JointMark, m: float) -> list[FloatArray]:
    """3-D outlines [m] of the joint's play magnified m times, around its magnified settled
    housing: a pin's circle, a ball's two great circles, a journal's two end circles at +/- L/2,
    a guide's rectangle of plays at each end of the block; none without play. Each outline is an
    array (K, 3) of points along it."""
    if not joint.has_play:
        return []
    centre = magnify(joint.housing, joint.housing_moved, m)
    x, y, z = joint.axes[:, 0], joint.axes[:, 1], joint.axes[:, 2]
    circle = np.outer(np.cos(CIRCLE), y) + np.outer(np.sin(CIRCLE), z)
    if joint.kind in ("planar_revolute", "spherical"):
        rings = [centre + m * joint.radial * circle]
        if joint.kind == "spherical":
            rings.append(centre + m * joint.radial * (np.outer(np.cos(CIRCLE), x)
                                                      + np.outer(np.sin(CIRCLE), y)))  # fmt: skip
        return rings
    half = 0.5 * joint.length
    if joint.kind in ("revolute", "cylindrical"):
        return [centre + side * half * x + m * joint.radial * circle for side in (-1.0, 1.0)]
    if joint.kind == "prismatic":
        corners = [(sy * joint.radial, sz * joint.play_z) for sy, sz in
                   ((-1, -1), (1, -1), (1, 1), (-1, 1), (-1, -1))]  # fmt: skip
        return [
            np.array([centre + side * half * x + m * (a * y + b * z) for a, b in corners])
            for side in (-1.0, 1.0)
        ]
    return []


def play_segments(joint: JointMark, m: float) -> list[tuple[FloatArray, FloatArray]]:
    """The outlines of ``joint``'s play magnified m times (:func:`play_outlines`) as segments."""
    return [
        (ring[i], ring[i + 1]) for ring in play_outlines(joint, m) for i in range(len(ring) - 1)
    ]


def force_arrows(
    bones: Skeleton, m: float, fraction: float
) -> list[tuple[str, str, tuple[FloatArray, FloatArray]]]:
    """The force arrows of a 3-D view, (group ``"contacts"`` or ``"loads"``, label, segment):
    each active contact's force ending at its magnified point, each applied load starting at
    its own, the largest force drawn ``fraction`` of the mechanism's size long [m/N alike]."""
    largest = max(
        [float(np.linalg.norm(c.force)) for c in bones.active_contacts]
        + [float(np.linalg.norm(f.force)) for f in bones.loads]
        + [0.0]
    )
    per_newton = fraction * bones.size() / largest if largest > 0.0 else 0.0  # [m/N]
    arrows = []
    for contact in bones.active_contacts:
        at = magnify(contact.point, contact.moved, m)
        arrows.append(("contacts", contact.label, (at - contact.force * per_newton, at)))
    for load in bones.loads:
        at = magnify(load.point, load.moved, m)
        arrows.append(("loads", load.label, (at, at + load.force * per_newton)))
    return arrows


def skeleton(equilibrium: Equilibrium) -> Skeleton:
    """The :class:`Skeleton` of ``equilibrium``'s mechanism, nominal and settled.

    Args:
        equilibrium: a solved :class:`~clearance_pin.equilibrium.result.Equilibrium` (either
            formulation) that carries its mechanism, configuration and body placements.

    Raises:
        ArgumentError: the equilibrium carries no mechanism or no solved pose.
    """
    if equilibrium.mechanism is None or equilibrium.configuration is None:
        raise ArgumentError(
            "equilibrium", "an Equilibrium returned by Mechanism.solve", "one without mechanism"
        )
    mechanism = cast("Mechanism", equilibrium.mechanism)
    configuration: Any = equilibrium.configuration
    model: Any = mechanism.model
    nominal_placements = tuple(configuration.oMi)
    placed = tuple(equilibrium.body_placements)
    if len(placed) != model.njoints:
        raise ArgumentError(
            "equilibrium.body_placements", f"{model.njoints} placements", f"{len(placed)}"
        )
    settled_frames = clearance_frames(equilibrium)
    nominal_frames = clearance_frames(replace(equilibrium, body_placements=nominal_placements))
    twists = None if equilibrium.body_twists is None else np.asarray(equilibrium.body_twists)
    points = _Points(nominal_placements, placed, twists)

    joints = []
    for tree_joint in mechanism.tree_joints:
        joints.append(
            _joint_mark(tree_joint, False, bool(tree_joint.driven), nominal_frames, points)
        )
    for loop_joint in mechanism.loop_joints:
        joints.append(_joint_mark(loop_joint, True, False, nominal_frames, points))

    contacts = _contact_marks(equilibrium, mechanism, nominal_frames, settled_frames, points)

    loads: list[LoadMark] = []
    torques: list[str] = []
    gravity = False
    for load in equilibrium.loads or mechanism.resolve_loads():
        if isinstance(load, PointForce):
            frame = model.frames[model.getFrameId(load.link)]
            local = frame.placement.act(np.asarray(load.point, dtype=float))
            start, end = points.add(frame.parentJoint, local)
            x, y, z = (float(v) for v in load.point)
            label = f"{load.link}@[{x:.6g} {y:.6g} {z:.6g}]"
            loads.append(LoadMark(label, start, end, np.asarray(load.force, dtype=float)))
        elif isinstance(load, Torque):
            torques.append(load.link)
        elif isinstance(load, Gravity):
            gravity = True

    outputs = []
    for output in equilibrium.output_points or _resolved_outputs(equilibrium, mechanism):
        start, end = points.add(output.body, np.asarray(output.placement.translation))
        outputs.append(OutputMark(output.name, start, end))

    size = _extent(points.nominal) or 1.0
    links = points.links(COINCIDENT * size)
    return Skeleton(
        name=str(mechanism.name),
        formulation=str(equilibrium.formulation),
        points=np.array(points.nominal, dtype=float).reshape(-1, 3),
        moved=np.array(points.moved, dtype=float).reshape(-1, 3),
        bodies=np.array(points.bodies, dtype=np.int64),
        links=links,
        joints=tuple(joints),
        contacts=contacts,
        loads=tuple(loads),
        torques=tuple(torques),
        gravity=gravity,
        outputs=tuple(outputs),
    )


class _Points:
    """The points carried by the parts, nominal and settled, collected as they are found."""

    def __init__(
        self, nominal: tuple[Any, ...], placed: tuple[Any, ...], twists: FloatArray | None
    ) -> None:
        self._nominal_placements = nominal
        self._placed = placed
        self._twists = twists
        self.nominal: list[FloatArray] = []
        self.moved: list[FloatArray] = []
        self.bodies: list[int] = []

    def add(self, body: int, local: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The point at ``local`` [m] of ``body``'s joint frame: (nominal, settled) world."""
        start = np.asarray(self._nominal_placements[body].act(local), dtype=float)
        end = self.move(body, start)
        self.add_world(body, start, end)
        return start, end

    def move(self, body: int, start: FloatArray) -> FloatArray:
        r"""Where the point of ``body`` nominally at ``start`` [m] settles: small-displacement
        model, :math:`p_0 + v_b + \omega_b \times p_0` (the displacement field the contact
        conditions are written on); exact model, the body's finite placement."""
        if self._twists is not None:
            twist = self._twists[body]
            return np.asarray(start + twist[:3] + np.cross(twist[3:], start), dtype=float)
        local = self._nominal_placements[body].actInv(start)
        return np.asarray(self._placed[body].act(local), dtype=float)

    def add_world(self, body: int, start: FloatArray, end: FloatArray) -> None:
        """A point of ``body`` given in world coordinates, nominal and settled [m]."""
        self.nominal.append(np.array(start, dtype=float))
        self.moved.append(np.array(end, dtype=float))
        self.bodies.append(int(body))

    def links(self, tolerance: float) -> tuple[tuple[int, int], ...]:
        """Each part's points joined by their shortest spanning tree (Prim), coincident points
        (closer than ``tolerance`` [m]) once."""
        segments: list[tuple[int, int]] = []
        nominal = np.array(self.nominal, dtype=float).reshape(-1, 3)
        for body in sorted(set(self.bodies)):
            members = [i for i, b in enumerate(self.bodies) if b == body]
            unique: list[int] = []
            for i in members:
                if all(np.linalg.norm(nominal[i] - nominal[k]) > tolerance for k in unique):
                    unique.append(i)
            if len(unique) < 2:
                continue
            reached, left = [unique[0]], unique[1:]
            while left:
                _, a, b = min(
                    (float(np.linalg.norm(nominal[a] - nominal[b])), a, b)
                    for a in reached
                    for b in left
                )
                segments.append((a, b))
                reached.append(b)
                left.remove(b)
        return tuple(segments)


def _joint_mark(
    joint: Any,
    loop: bool,
    driven: bool,
    nominal_frames: dict[str, ClearanceFrames],
    points: _Points,
) -> JointMark:
    nominal = nominal_frames[joint.name]
    housing = np.asarray(nominal.parent.translation, dtype=float)
    journal = np.asarray(nominal.child.translation, dtype=float)
    housing_moved = points.move(nominal.parent_body, housing)
    journal_moved = points.move(nominal.child_body, journal)
    points.add_world(nominal.parent_body, housing, housing_moved)
    points.add_world(nominal.child_body, journal, journal_moved)
    clearance = joint.clearance
    if clearance.kind in ("revolute", "cylindrical", "prismatic") and clearance.length > 0.0:
        # the journal's or block's axis (child) and the bore's or guide's (parent), L long
        for side in (-0.5, 0.5):
            end = np.array([side * clearance.length, 0.0, 0.0])
            for body, frame in ((nominal.child_body, nominal.child),
                                (nominal.parent_body, nominal.parent)):  # fmt: skip
                start = np.asarray(frame.act(end), dtype=float)
                points.add_world(body, start, points.move(body, start))
    return JointMark(
        name=str(joint.name),
        kind=str(clearance.kind),
        loop=loop,
        driven=driven,
        parent_body=int(nominal.parent_body),
        child_body=int(nominal.child_body),
        axes=np.array(nominal.parent.rotation, dtype=float),
        housing=housing,
        housing_moved=housing_moved,
        journal=journal,
        journal_moved=journal_moved,
        radial=float(clearance.radial),
        play_z=float(clearance.radial if clearance.play_z is None else clearance.play_z),
        axial=float(clearance.axial),
        length=float(clearance.length),
    )


def _contact_marks(
    equilibrium: Equilibrium,
    mechanism: Mechanism,
    nominal_frames: dict[str, ClearanceFrames],
    settled_frames: dict[str, ClearanceFrames],
    points: _Points,
) -> tuple[ContactMark, ...]:
    """Every contact of ``equilibrium``: the child's contact point (nominal, settled) and its
    force in world axes (the parent-side clearance frame's: nominal for the small-displacement
    model, settled for the exact one, as :class:`~clearance_pin.Contact` states)."""
    marks = []
    for contact in equilibrium.contacts:
        joint: Any = mechanism.joints[contact.joint]
        spec = next(p for p in joint.clearance.contacts if p.name == contact.point)
        nominal, settled = nominal_frames[contact.joint], settled_frames[contact.joint]
        local = np.asarray(spec.point, dtype=float)
        start = np.asarray(nominal.child.act(local), dtype=float)
        parent = settled.parent if equilibrium.formulation == "exact" else nominal.parent
        rotation = np.asarray(parent.rotation, dtype=float)
        marks.append(
            ContactMark(
                label=contact.label,
                joint=contact.joint,
                point=start,
                moved=points.move(nominal.child_body, start),
                force=rotation @ np.asarray(contact.force, dtype=float),
                active=bool(contact.active),
                shape=str(spec.shape),
                directions=np.asarray(nominal.parent.rotation, dtype=float)[
                    :, list(spec.components)
                ],
                bound=float(spec.bound),
            )
        )
    return tuple(marks)


def _resolved_outputs(equilibrium: Equilibrium, mechanism: Mechanism) -> tuple[Any, ...]:
    from ..equilibrium.outputs import resolve_outputs

    return tuple(resolve_outputs(mechanism, equilibrium.loads or ()))


def _extent(points: list[FloatArray]) -> float:
    if not points:
        return 0.0
    return float(np.linalg.norm(np.ptp(np.array(points), axis=0)))


def _points_plane(points: FloatArray, size: float) -> FloatArray | None:
    """The normal of the plane the points span, None when they span 3-D or a line."""
    if len(points) < 3:
        return None
    centred = points - points.mean(axis=0)
    _, singular, vt = np.linalg.svd(centred)
    if singular[2] > COINCIDENT * size * np.sqrt(len(points)) or singular[1] <= COINCIDENT * size:
        return None
    return np.asarray(vt[2], dtype=float)


def plane_axes(normal: FloatArray) -> tuple[FloatArray, FloatArray, str, str]:
    """Two in-plane unit axes (e1, e2, with e1 x e2 = normal) and their names for the axis labels:
    world axes where the normal is one (``x``, ``y`` for a normal along z), else the directions.
    """
    n = normal / np.linalg.norm(normal)
    k = int(np.argmax(np.abs(n)))
    if abs(abs(n[k]) - 1.0) < 1e-9:
        i, j = (k + 1) % 3, (k + 2) % 3
        e1, e2 = np.eye(3)[i], np.eye(3)[j] * np.sign(n[k])
        names = "xyz"
        return e1, e2, names[i], ("" if n[k] > 0 else "-") + names[j]
    seed = np.eye(3)[int(np.argmin(np.abs(n)))]
    e1 = seed - (seed @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    return e1, e2, _direction(e1), _direction(e2)


def _direction(d: FloatArray) -> str:
    return "(" + ", ".join(f"{v:+.2f}" for v in d) + ")"

r"""Clearance kinds of a joint: which relative motions are free, rigid, or bounded by play.

A joint k relates a child part to a parent part. In the joint's *clearance frame* (origin at the
joint centre :math:`O_k`, x axis along the joint axis) their small relative motion is the torsor

.. math::  T_k = (u, v, w, \alpha, \beta, \gamma) = (V_k, \Omega_k)

(Pinocchio's order: translation first, [m] then [rad]). A point of the child at :math:`r` (in the
clearance frame, [m]) is displaced by :math:`V + \Omega \times r` in the small-displacement model and
by :math:`p + R r - r` in the exact one, where :math:`(R, p)` is the finite relative placement.

Each kind (docs/method.md section 2, after Younes, Dal Santo & Potiron) declares:

- *free* components: the ideal joint's own motion (spin of a journal, swivel of a ball);
- *rigid* components: zero whatever the load (the out-of-plane motion of a planar pin);
- *contact points*: points of the child whose selected displacement components stay inside a
  clearance set: a ball or disc (``norm``, :math:`\|d_{sel}\| \le c`) or a slab (``abs``,
  :math:`|d_i| \le c`). The journal of a cylindrical joint, for example, has two contact points,
  the ends of its axis at :math:`x = \pm L/2`, each kept within the radial clearance ``c`` of the bore
  axis: :math:`(v + \gamma x)^2 + (w - \beta x)^2 \le c^2` at :math:`x = \pm L/2` ([Y], cylindrical
  joint).

``rigid`` (a weld) and ``free`` (a floating body, no joint) complete the list.

A contact point with a zero clearance is a rigid condition; the solver turns it into equalities.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, NotFoundError

U, V, W, ALPHA, BETA, GAMMA = range(6)
COMPONENT_NAMES = ("u", "v", "w", "alpha", "beta", "gamma")
COMPONENT_MEANING = (
    "slide along the joint axis",
    "translation across the axis (y)",
    "translation across the axis (z)",
    "spin about the joint axis",
    "tilt about y",
    "tilt about z",
)

KINDS = ("spherical", "cylindrical", "revolute", "prismatic", "planar_revolute", "rigid", "free")
BACKLASH_KINDS = ("cylindrical", "revolute", "prismatic", "planar_revolute")
BACKLASH_LEVER = 0.01  # [m] the lever of a drive's lost motion on a joint without a length


@dataclass(frozen=True)
class ContactPoint:
    """A point of the child part kept inside a clearance set around its nominal position.

    Attributes:
        name: short label, unique within the joint (``"ball"``, ``"end-"``, ``"axial"``, ...).
        point: position in the clearance frame [m], shape (3,).
        components: indices (0=x, 1=y, 2=z) of the displacement that the set bounds.
        shape: ``"norm"`` (ball or disc: Euclidean norm of the components <= bound) or
            ``"abs"`` (slab: |component| <= bound, one component).
        bound: the clearance that bounds it [m] (radial, axial, or a play).
        lever: 0 for a point; > 0 [m] for a drive's lost motion (backlash): the set then bounds
            the *rotation* about the axes ``components`` times ``lever``, the travel it gives at
            that radius (:math:`|\\alpha| \\rho \\le b \\rho / 2`; a length, like every
            bound, whatever the radius: the answer does not depend on it).
    """

    name: str
    point: tuple[float, float, float]
    components: tuple[int, ...]
    shape: str
    bound: float
    lever: float = 0.0

    def linear_rows(self) -> np.ndarray:
        r"""Rows :math:`S [I, -[r]_\times]` mapping the torsor T (6,) to the bounded components
        (a lever's: :math:`\rho\, e_{3+k}`).

        Returns:
            array of shape (len(components), 6).
        """
        if self.lever:
            return _rotation_rows(self.lever, self.components)
        return _linear_rows(self.point, self.components)

    def displacement(self, rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
        """The bounded components [m] under a finite relative motion (R, p) of the child in the
        clearance frame: the point's :math:`p + R r - r`, or a lever's rotation vector
        :math:`\\rho \\log(R)` (Pinocchio's log3)."""
        if self.lever:
            turned = np.asarray(pin.log3(rotation), dtype=float)
            return np.asarray(self.lever * turned[list(self.components)])
        r = np.asarray(self.point, dtype=float)
        moved: np.ndarray = translation + rotation @ r - r
        return moved[list(self.components)]


@lru_cache(maxsize=4096)
def _linear_rows(point: tuple[float, float, float], components: tuple[int, ...]) -> np.ndarray:
    x, y, z = point
    displacement = np.array(
        [
            [1.0, 0.0, 0.0, 0.0, z, -y],
            [0.0, 1.0, 0.0, -z, 0.0, x],
            [0.0, 0.0, 1.0, y, -x, 0.0],
        ]
    )
    rows = displacement[list(components)]
    rows.setflags(write=False)
    return rows


@lru_cache(maxsize=64)
def _rotation_rows(lever: float, components: tuple[int, ...]) -> np.ndarray:
    rows = np.zeros((len(components), 6))
    for row, component in enumerate(components):
        rows[row, 3 + component] = lever
    rows.setflags(write=False)
    return rows


@dataclass(frozen=True)
class Clearance:
    """The clearance kind of one joint with its dimensions (SI).

    Attributes:
        kind: one of :data:`KINDS`.
        radial: radial clearance c = J/2 [m] (spherical, cylindrical, revolute, planar_revolute);
            for prismatic, the play across the axis in y.
        length: journal / block length L [m] (cylindrical, revolute, prismatic).
        axial: axial play c_a [m] of a revolute joint (|u| <= c_a).
        play_z: prismatic play in z [m] (defaults to ``radial``).
        width: prismatic block width along y [m]; 0 leaves the roll free.
        height: prismatic block height along z [m]; 0 leaves the roll free.
        backlash: a driven joint's total lost motion [rad for the revolute kinds, m for
            prismatic]: the joint turns (slides) within +/- backlash / 2 of its command, a
            contact ``"backlash"`` on its own motion (0: the drive holds it rigidly).
        stiffness: K (6, 6) in the clearance frame as nested tuples [N/m, N m/rad], an elastic
            deflection in series with the play (:mod:`.stiffness`); None: rigid.
        stiffness_frame: which part K is fixed in: ``"housing"`` (the parent's side: K does not
            turn with the joint's own angle; default) or ``"part"`` (the child's side: K turns
            with it). The same for a K symmetric about the joint's axis (:mod:`.stiffness`).
    """

    kind: str
    radial: float = 0.0
    length: float = 0.0
    axial: float = 0.0
    play_z: float | None = None
    width: float = 0.0
    height: float = 0.0
    backlash: float = 0.0
    stiffness: tuple[tuple[float, ...], ...] | None = None
    stiffness_frame: str = "housing"
    contacts: tuple[ContactPoint, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise NotFoundError("clearance kind", self.kind, KINDS, where="Clearance(kind)")
        for name in ("radial", "length", "axial", "width", "height", "backlash"):
            _check_nonnegative(name, getattr(self, name))
        if self.play_z is not None:
            _check_nonnegative("play_z", self.play_z)
        if self.stiffness_frame not in ("housing", "part"):
            raise NotFoundError(
                "stiffness frame", self.stiffness_frame, ("housing", "part"), "stiffness_frame"
            )
        if self.kind in ("cylindrical", "revolute", "prismatic") and not self.length > 0.0:
            raise ArgumentError(
                f"Clearance({self.kind!r}, length)",
                "a journal or block length > 0 [m]",
                self.length,
            )
        if self.backlash and self.kind not in BACKLASH_KINDS:
            raise ArgumentError(
                f"Clearance({self.kind!r}, backlash)",
                f"a joint that turns or slides ({', '.join(BACKLASH_KINDS)})",
                self.backlash,
            )
        contacts = self._contact_points()
        if self.backlash:
            contacts.append(self._backlash_contact())
        object.__setattr__(self, "contacts", tuple(contacts))

    def _backlash_contact(self) -> ContactPoint:
        """The drive's lost motion: a slab on the slide u (prismatic, [m]) or on the spin alpha
        at the lever of half the journal's length (revolute kinds, :attr:`ContactPoint.lever`)."""
        half = 0.5 * self.backlash
        if self.kind == "prismatic":
            return ContactPoint("backlash", (0.0, 0.0, 0.0), (0,), "abs", half)
        lever = 0.5 * self.length if self.length > 0.0 else BACKLASH_LEVER
        return ContactPoint("backlash", (0.0, 0.0, 0.0), (0,), "abs", half * lever, lever)

    @property
    def rigid_components(self) -> tuple[int, ...]:
        """Torsor components that are zero whatever the load."""
        if self.kind == "rigid":
            return (U, V, W, ALPHA, BETA, GAMMA)
        if self.kind == "planar_revolute":
            return (U, BETA, GAMMA)
        return ()

    @property
    def free_components(self) -> tuple[int, ...]:
        """Torsor components of the ideal joint's own motion (unbounded unless driven)."""
        free = {
            "spherical": (ALPHA, BETA, GAMMA),
            "cylindrical": (U, ALPHA),
            "revolute": (ALPHA,),
            "planar_revolute": (ALPHA,),
            "rigid": (),
            "free": (U, V, W, ALPHA, BETA, GAMMA),
        }
        if self.kind == "prismatic":
            return (U,) if (self.width > 0.0 or self.height > 0.0) else (U, ALPHA)
        return free[self.kind]

    @property
    def max_play(self) -> float:
        """Largest clearance of the joint [m] (0 for an ideal joint)."""
        return max((c.bound for c in self.contacts), default=0.0)

    def _contact_points(self) -> list[ContactPoint]:
        half = 0.5 * self.length
        if self.kind == "spherical":
            return [ContactPoint("ball", (0.0, 0.0, 0.0), (0, 1, 2), "norm", self.radial)]
        if self.kind == "planar_revolute":
            return [ContactPoint("pin", (0.0, 0.0, 0.0), (1, 2), "norm", self.radial)]
        if self.kind in ("cylindrical", "revolute"):
            points = [
                ContactPoint("end-", (-half, 0.0, 0.0), (1, 2), "norm", self.radial),
                ContactPoint("end+", (half, 0.0, 0.0), (1, 2), "norm", self.radial),
            ]
            if self.kind == "revolute":
                points.append(ContactPoint("axial", (0.0, 0.0, 0.0), (0,), "abs", self.axial))
            return points
        if self.kind == "prismatic":
            return self._block_corners(half)
        return []

    def _block_corners(self, half: float) -> list[ContactPoint]:
        play_z = self.radial if self.play_z is None else self.play_z
        ys = sorted({-0.5 * self.width, 0.5 * self.width})
        zs = sorted({-0.5 * self.height, 0.5 * self.height})
        points = []
        for x in (-half, half):
            for y in ys:
                for z in zs:
                    label = f"({_sign(x)}{_sign(y)}{_sign(z)})"
                    points.append(
                        ContactPoint(f"corner{label}.y", (x, y, z), (1,), "abs", self.radial)
                    )
                    points.append(ContactPoint(f"corner{label}.z", (x, y, z), (2,), "abs", play_z))
        return points


def ideal(kind: str, length: float = 1.0) -> Clearance:
    """An ideal joint (no play) of the given kind: every contact point has a zero bound.

    An ideal prismatic joint (a URDF ``prismatic`` joint) constrains what its URDF type
    constrains: everything but the slide, so its block has a width and a height (the roll about
    the axis is held too)."""
    if kind == "prismatic":
        return Clearance(kind, 0.0, length=length, width=length, height=length)
    if kind in ("cylindrical", "revolute"):
        return Clearance(kind, 0.0, length=length)
    return Clearance(kind, 0.0)


def _sign(value: float) -> str:
    return "0" if value == 0.0 else ("+" if value > 0.0 else "-")


def _check_nonnegative(name: str, value: float) -> None:
    if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0.0:
        raise ArgumentError(f"Clearance({name})", "a finite number >= 0 [m]", value)

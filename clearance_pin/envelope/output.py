r"""The output of an envelope: a point of one part with axes, where the deviation is read.

An output is a Pinocchio frame (its origin and axes), or a point of a link: ``(link, point)``
with ``point`` [m] in the link frame, or the text ``"link@[x y z]"``. It belongs to one body $b$
(a Pinocchio joint); the unit loads of the support function (:mod:`.support`) act on a URDF link
of that body at the output point. Its deviation, world axes, is

- translation: the displacement [m] of the point, $v_b + \omega_b \times p$ (small-displacement
  model), $t_l + (\exp(\omega_l) - I) r$ from the link's finite motion $(t_l, \omega_l)$ (exact
  model), $r$ the point relative to the link origin, world axes;
- rotation: the rotation [rad] of the part, $\omega_b$ (small displacements) or
  $\log_3(R R_0^T)$ (exact).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from ..arguments import check_point
from ..errors import ArgumentError, NotFoundError
from ..model.frames import parse_point, point_name

Vector = npt.NDArray[np.float64]
Kind = Literal["translation", "rotation"]
KINDS: tuple[Kind, ...] = ("translation", "rotation")


@dataclass(frozen=True)
class Output:
    """Where the envelope is read.

    Attributes:
        name: the frame name, or ``link@[x y z]`` for a point of a link ([m], link frame).
        link: the URDF link (Pinocchio BODY frame) of the part that carries it: the loads of the
            support function act on it.
        point: the output point in that link's frame [m], (3,).
        body: Pinocchio joint index of the part.
        position: the point in the world at the nominal configuration [m], (3,).
        axes: the output frame's axes in the world, columns (3, 3) (the link's for a point).
        link_position: the link frame's origin in the world [m], (3,).
    """

    name: str
    link: str
    point: Vector
    body: int
    position: Vector
    axes: Vector
    link_position: Vector

    def deviation(self, equilibrium: Any, kind: Kind) -> Vector:
        r"""The output's deviation in ``equilibrium`` [m or rad], world axes, (3,).

        Translation: $t_l + \omega_l \times r$ (linear) or $t_l + (\exp(\omega_l) - I) r$
        (exact), $(t_l, \omega_l)$ = ``equilibrium.frame_displacement(link)``, $r$ the point
        relative to the link origin in world axes. Rotation: $\omega_l$.
        """
        translation, rotation = equilibrium.frame_displacement(self.link)
        translation = np.asarray(translation, dtype=float)
        rotation = np.asarray(rotation, dtype=float)
        if kind == "rotation":
            return rotation
        lever = self.position - self.link_position
        if equilibrium.formulation == "exact":
            turned = np.asarray(pin.exp3(rotation)) @ lever - lever
            return np.asarray(translation + turned, dtype=float)
        return np.asarray(translation + np.cross(rotation, lever), dtype=float)


def resolve_output(mechanism: Any, output: object, configuration: Any) -> Output:
    """The :class:`Output` named by ``output`` at ``configuration`` (a
    :class:`~clearance_pin.mechanism.Configuration`).

    Args:
        mechanism: the mechanism.
        output: a Pinocchio frame name, ``"link@[x y z]"`` or ``(link, (x, y, z))`` [m].
        configuration: where the mechanism stands (nominal placements).

    Raises:
        NotFoundError: an unknown frame or link (the valid names listed).
        ArgumentError: a malformed point, or an output on the ground (it cannot move).
    """
    model = mechanism.model
    link, point, name = _parse(mechanism, output)
    if link is None:  # a frame
        if not model.existFrame(name):
            raise NotFoundError(
                "frame", name, [f.name for f in model.frames], where=f"envelope({mechanism.name})"
            )
        frame_id = model.getFrameId(name)
        body = int(model.frames[frame_id].parentJoint)
        link_id = _link_of_body(mechanism, body, name)
        link_frame = model.frames[link_id]
        local = link_frame.placement.actInv(model.frames[frame_id].placement)
        link, point = link_frame.name, np.array(local.translation, dtype=float)
        axes = np.array(configuration.oMf[frame_id].rotation, dtype=float)
    else:
        link_id = mechanism.link_frames[link]
        body = int(model.frames[link_id].parentJoint)
        axes = np.array(configuration.oMf[link_id].rotation, dtype=float)
    if body == 0:
        raise ArgumentError(
            "output", "a frame or point of a moving part", name, "it is on the ground"
        )
    placed = configuration.oMf[link_id]
    position = np.array(placed.act(point), dtype=float)
    return Output(
        name=name,
        link=str(link),
        point=np.array(point, dtype=float),
        body=body,
        position=position,
        axes=axes,
        link_position=np.array(placed.translation, dtype=float),
    )


def _parse(mechanism: Any, output: object) -> tuple[str | None, Vector, str]:
    """(link or None for a frame, point in the link frame, display name)."""
    if isinstance(output, str):
        parsed = parse_point(output)
        if parsed is None:
            return None, np.zeros(3), output.strip()
        return _checked_point(mechanism, parsed[0], parsed[1], output)
    if isinstance(output, tuple) and len(output) == 2 and isinstance(output[0], str):
        try:
            point = np.array(output[1], dtype=float).reshape(-1)
        except (TypeError, ValueError):
            point = np.zeros(0)
        return _checked_point(mechanism, output[0], point, output)
    raise ArgumentError("output", "a frame name, 'link@[x y z]' or (link, (x, y, z)) [m]", output)


def _checked_point(
    mechanism: Any, link: str, point: Vector, given: object
) -> tuple[str, Vector, str]:
    if link not in mechanism.link_frames:
        raise NotFoundError(
            "link", link, tuple(mechanism.link_frames), where=f"envelope({mechanism.name})"
        )
    if point.shape != (3,) or not np.all(np.isfinite(point)):
        raise ArgumentError("output", "a point of 3 finite numbers [m], link frame", given)
    check_point("output", point, given)
    return link, point, point_name(link, point)


def _link_of_body(mechanism: Any, body: int, name: str) -> int:
    """The frame id of a URDF link of ``body`` (the body frame itself when the frame is one)."""
    model = mechanism.model
    if (
        name in mechanism.link_frames
        and model.frames[mechanism.link_frames[name]].parentJoint == body
    ):
        return int(mechanism.link_frames[name])
    for frame_id in mechanism.link_frames.values():
        if model.frames[frame_id].parentJoint == body:
            return int(frame_id)
    raise ArgumentError(
        "output", "a frame of a part that carries a URDF link", name, "no link on its body"
    )

r"""One point of a tree's trajectory: the nominal prepared geometry, moved to a configuration.

A mechanism without loop joints has one reduced geometry for all its configurations
(:func:`.prepared._reduced`), and its joint torsors read the unknowns the same way everywhere
(:math:`T_k = B_k t_k`): only the body twists and the joint centres follow the configuration.
A :class:`TreePoint` shares everything else with the nominal
:class:`~.prepared.PreparedGeometry` and forms the rest from the configuration's joint placements
when an answer is assembled, the body twist of body i as Pinocchio forms a Jacobian
(:mod:`.small_displacement`),

.. math::  \xi_i = \xi_{\lambda(i)} + \mathrm{Ad}(oM_i\, C_k)\, B_k\, t_k,

so a read trajectory keeps per point its answer and its configuration, not a geometry of maps
(tens of kB each for a 6R arm).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..errors import ClearancePinError

if TYPE_CHECKING:
    from ..model.mechanism_parts import ConfigurationParts as Configuration
    from .prepared import PreparedGeometry


class TreePoint:
    """The prepared geometry of a tree at ``configuration``, sharing ``nominal``'s
    configuration-independent terms (geometry, stacked contact terms, torsor maps).

    Attributes:
        nominal: the tree's prepared geometry at its nominal configuration.
        configuration: this point's :class:`~clearance_pin.mechanism.Configuration`.
    """

    def __init__(self, nominal: PreparedGeometry, configuration: Configuration):
        if nominal.mechanism.loop_joints:
            raise ClearancePinError("a trajectory point shares its geometry only in a tree")
        self.nominal = nominal
        self.configuration = configuration

    def __getattr__(self, name: str) -> Any:
        # the configuration-independent members: mechanism, geometry, terms, maps (their torsor
        # maps; the centres are this point's, joint_centres), length, bodies, bounds, ...
        nominal = self.__dict__.get("nominal")
        if nominal is None:
            raise AttributeError(name)
        return getattr(nominal, name)

    def joint_centres(self) -> dict[str, pin.SE3]:
        """Joint name -> clearance frame placement oM_c in the world at this configuration."""
        oMi = self.configuration.oMi
        return {
            joint.name: oMi[joint.joint_id] * pin.SE3(joint.rotation, np.zeros(3))
            for joint in self.nominal.mechanism.tree_joints
        }

    def body_twists(self, x: np.ndarray) -> np.ndarray:
        """Spatial twist (v, omega) at the world origin of every body, (bodies, 6), formed as
        :func:`.small_displacement.build_maps` forms its maps (the same numbers)."""
        mechanism = self.nominal.mechanism
        model, oMi = mechanism.model, self.configuration.oMi
        torsors = self.nominal.maps.joint_torsor  # the same at every configuration of a tree
        by_id = {joint.joint_id: joint for joint in mechanism.tree_joints}
        rows = np.zeros((model.njoints, 6, x.shape[-1]))
        for i in range(1, model.njoints):  # a parent before its children
            joint = by_id[i]
            oMc = oMi[i] * pin.SE3(joint.rotation, np.zeros(3))
            rows[i] = rows[model.parents[i]] + oMc.action @ torsors[joint.name]
        twists: np.ndarray = (rows.reshape(-1, x.shape[-1]) @ x).reshape(model.njoints, 6)
        return twists

    def body_motions(self, twists: np.ndarray, names: Any) -> dict[str, Any]:
        """Body name -> (translation of its frame origin [m], rotation [rad]), world axes."""
        origins = np.array([m.translation for m in self.configuration.oMi])
        return body_motions(twists, origins, names)


def body_motions(twists: np.ndarray, origins: np.ndarray, names: Any) -> dict[str, Any]:
    r"""Body name -> (:math:`v_i + \omega_i \times p_i` [m], :math:`\omega_i` [rad]): the motion of
    each body's frame origin p_i (bodies, 3) [m] from its twist at the world origin (bodies, 6)."""
    w, p = twists[:, 3:], origins
    moved = twists[:, :3] + np.stack(
        (
            w[:, 1] * p[:, 2] - w[:, 2] * p[:, 1],
            w[:, 2] * p[:, 0] - w[:, 0] * p[:, 2],
            w[:, 0] * p[:, 1] - w[:, 1] * p[:, 0],
        ),
        axis=1,
    )
    return {names[i]: (moved[i], twists[i, 3:]) for i in range(1, len(twists))}


__all__ = ["TreePoint", "body_motions"]

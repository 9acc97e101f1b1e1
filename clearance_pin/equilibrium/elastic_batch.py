r"""Batches of a tree with joint stiffness, by superposition on arrays (:mod:`.elastic_tree`).

In a tree no contact reads an elastic unknown, so every case splits into the answer of the rigid
twin (:func:`.elastic_tree.play_twin`, solved as a batch by its own engines: closed forms, the
compiled kernel, the NumPy batch) and each spring's deflection under its joint's reaction,

.. math::  e_j = -K_j^{+} R_j ,

with :math:`R_j` (N, 6) the wrench the parent exerts on the child through joint j in its
clearance frame, read for every case at once from the twin's batch (statics of the subtree: the
same with or without springs in a tree), and :math:`K_j^{+}` the compliance on the directions that
deflect (:func:`.elastic_tree.spring_deflections`; a K stated in the housing's frame is
turned into the part's at each case's pose, :math:`-G^T K^+ G R_j`,
:mod:`~clearance_pin.model.stiffness`). A joint's torsor is its play's plus :math:`e_j`;
the bodies' twists are composed from the torsors along the tree
(:func:`.batch_answers.torsor_twists`); the energy is the play's less
:math:`\tfrac12 \sum_j e_j^T K_j e_j`. Reactions, contact forces and drive torques are the twin's.
An item is assembled when read, as a single solve assembles it (:func:`.elastic_tree.superposed`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from concurrent.futures import Executor
from typing import TYPE_CHECKING, Any

import numpy as np

from ..model.stiffness import elastic, turning
from ..numerics import Array, Mask
from .batch import EquilibriumBatch
from .batch_answers import torsor_twists
from .batch_kinematics import body_placements
from .batch_reactions import in_frame, subtree_statics_hold, tree_reactions
from .elastic_tree import play_twin, spring_deflections, superposed, superposed_status, turned
from .method import NO_LOAD_STATUS, Method
from .options import SolveOptions
from .prepared import prepared_geometry

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism
    from .batch import Cases


def solve_superposed(
    mechanism: Mechanism,
    cases: Cases,
    options: SolveOptions,
    errors: str,
    progress: bool | None,
    executor: Executor | None = None,
    chunks: int | None = None,
) -> ElasticTreeBatch:
    """The linear answers of ``cases`` of ``mechanism`` (a tree with stiffness): the rigid twin's
    batch (in ``executor``'s tasks when one is given) plus the springs (module docstring)."""
    from .batch import solve_many

    twin = play_twin(mechanism)
    play: EquilibriumBatch
    if not prepared_geometry(twin).geometry.contacts:  # no play anywhere: the springs alone
        play = RigidPlay(twin, cases, options)
    else:
        play = solve_many(
            twin, cases.loads, cases.configurations, options,
            executor=executor, chunks=chunks, errors=errors, progress=progress,
        )  # fmt: skip
    return ElasticTreeBatch(mechanism, play, cases, options)


class RigidPlay(EquilibriumBatch):
    """The rigid twin's batch when no joint has play: nothing moves in any case (torsors 0, every
    case verified, energy 0, no contact), each joint's whole reaction the statics of its subtree
    (:func:`.batch_reactions.tree_reactions`, where it gives it: :func:`.batch_reactions.
    subtree_statics_hold`); a case's answer, or a reaction's parts, by a single solve of the
    twin when read."""

    def __init__(self, twin: Mechanism, cases: Cases, options: SolveOptions) -> None:
        from .formulation import solve_with_options

        def solve(index: int) -> Any:
            loads, q = cases[index]
            return solve_with_options(twin, loads, q, options)

        super().__init__([None] * len(cases), None, solve)
        self.twin, self._cases, self._options = twin, cases, options

    def torsors(self, joint: str) -> Array:
        self._check_joint(joint)
        return np.zeros((len(self), 6))

    @property
    def ok(self) -> Array:
        return np.ones(len(self), dtype=bool)

    @property
    def energy(self) -> Array:
        return np.zeros(len(self))

    def reactions(self, joint: str, frame: str = "joint", part: str | None = None) -> Array:
        """The whole reaction from the subtree's statics; its parts by single solves."""
        self._check_joint(joint)
        if part is not None or not subtree_statics_hold(self.twin, joint):
            return super().reactions(joint, frame, part)
        placed = self.__dict__.get("_placed")
        if placed is None:
            placed = self.__dict__["_placed"] = _placements(self.twin, self._cases.configurations)
            self.__dict__["_whole"] = tree_reactions(
                self.twin, self._cases.load_column(), self._options.gravity, *placed
            )
        return in_frame(self.twin, joint, self.__dict__["_whole"][joint], frame, *placed)

    @property
    def methods(self) -> list[Method | str]:
        return [Method.NO_LOAD] * len(self)

    @property
    def statuses(self) -> list[str]:
        return [NO_LOAD_STATUS] * len(self)

    def contact_forces(self, joint: str) -> Array:
        self._check_joint(joint)
        return np.zeros((len(self), 0, 3))

    def contact_points(self, joint: str) -> tuple[str, ...]:
        self._check_joint(joint)
        return ()

    def _mechanism(self) -> Any:
        return self.twin


class ElasticTreeBatch(EquilibriumBatch):
    """The batch of a tree with stiffness: the rigid twin's batch ``play`` and the springs'
    deflections (module docstring); the readers of :class:`.batch.EquilibriumBatch`."""

    def __init__(
        self, mechanism: Mechanism, play: EquilibriumBatch, cases: Cases, options: SolveOptions
    ) -> None:
        self.mechanism, self.play = mechanism, play
        self._cases, self._options = cases, options
        started = time.perf_counter()
        stiff = [joint for joint in mechanism.tree_joints if elastic(joint.clearance)[1].size]
        self._placed = _placements(mechanism, cases.configurations)
        reactions = tree_reactions(mechanism, cases.load_column(), options.gravity, *self._placed)
        housing = {joint.name for joint in turning(stiff)}  # K turned per case: its G
        self._turns = {name: self._part_turns(mechanism.joints[name]) for name in housing}
        self._springs = {
            joint.name: spring_deflections(
                joint, reactions[joint.name], self._turns.get(joint.name)
            )
            for joint in stiff
        }
        self._started = started
        super().__init__([self._item_builder(i) for i in range(len(play))])

    def _part_turns(self, joint: Any) -> Array:
        """Per case (K, 3, 3) the part's rotation relative to its housing, clearance-frame axes
        (:func:`~clearance_pin.model.stiffness.part_rotation` on the cases' placements)."""
        rotations = self._placed[0]
        model = self.mechanism.model
        i = joint.joint_id
        placement = np.asarray(model.jointPlacements[i].rotation)
        own = np.einsum(
            "ba,kcb,kcd->kad", placement, rotations[:, int(model.parents[i])], rotations[:, i]
        )  # M_J^T R_p^T R_i
        C = joint.rotation
        turns: Array = np.einsum("ba,kbc,cd->kad", C, own, C)  # C^T own C
        return turns

    def _item_builder(self, index: int) -> Any:
        def build() -> Any:
            answer = self.play[index]
            if isinstance(answer, Exception):
                return answer
            loads, q = self._cases[index]
            mechanism = self.mechanism
            prepared = prepared_geometry(mechanism, None if q is None else np.asarray(q))
            resolved = mechanism.resolve_loads(loads, self._options.gravity)
            return superposed(mechanism, prepared, resolved, answer, self._started)

        return build

    @property
    def methods(self) -> list[Method | str]:
        """The play's engine per case, closed forms where the springs alone move (as the items
        say: :func:`.elastic_tree.superposed`)."""
        alone = self._springs_alone()
        return [Method.CLOSED_FORM if a else m for m, a in zip(self.play.methods, alone)]

    @property
    def statuses(self) -> list[str]:
        """Per case: the play's status and the springs' superposition, as the items say."""
        alone = self._springs_alone()
        return [
            superposed_status(status, moving) if isinstance(method, Method) else status
            for method, status, moving in zip(self.play.methods, self.play.statuses, alone)
        ]  # an error's class name (a str, not a Method) as it is

    def _springs_alone(self) -> list[bool]:
        """Per case: nothing moves in the play but a spring deflects (a closed form alone)."""
        deflecting = np.zeros(len(self), dtype=bool)
        for spring in self._springs.values():
            deflecting |= np.any(spring != 0.0, axis=1)
        return [
            method is Method.NO_LOAD and bool(moving)
            for method, moving in zip(self.play.methods, deflecting)
        ]

    def torsors(self, joint: str) -> Array:
        """Torsor of ``joint`` (play and spring) in every case, (N, 6) [m, rad]."""
        return self.play.torsors(joint) + self.deflections(joint)

    def deflections(self, joint: str) -> Array:
        """The spring deflection of ``joint`` in every case, (N, 6) [m, rad] (zero for a rigid
        joint; NaN for failed cases)."""
        self._check_joint(joint)
        return np.where(self._solved(), self._springs.get(joint, 0.0), np.nan)

    def _solved(self) -> Mask:
        """Per case (N, 1): the play has an answer (an error's row reads NaN), read once."""
        solved: Mask | None = self.__dict__.get("_solved_rows")
        if solved is None:
            first = self.mechanism.tree_joints[0].name
            solved = np.isfinite(self.play.torsors(first)).all(axis=1, keepdims=True)
            self.__dict__["_solved_rows"] = solved
        return solved

    def frame_displacements(self, frame: str) -> tuple[Array, Array]:
        """World displacement of a Pinocchio frame in every case (translations (N, 3) [m],
        rotations (N, 3) [rad]), the bodies' twists composed from the joints' torsors."""
        from ..errors import NotFoundError
        from ..model.frames import frame_id as find_frame

        model = self.mechanism.model
        frame_id = find_frame(model, frame)
        if frame_id is None:
            names = [f.name for f in model.frames]
            raise NotFoundError("frame", frame, names, self.mechanism.name)
        rotations, translations = self._placed
        torsors = {joint.name: self.torsors(joint.name) for joint in self.mechanism.tree_joints}
        twists = torsor_twists(self.mechanism, rotations, translations, torsors)
        placed = model.frames[frame_id]
        body = placed.parentJoint
        rotation = rotations[:, body]
        origin = rotation @ placed.placement.translation + translations[:, body]
        translation = twists[:, body, :3] + np.cross(twists[:, body, 3:], origin)
        return translation, twists[:, body, 3:].copy()

    def reactions(self, joint: str, frame: str = "joint", part: str | None = None) -> Array:
        """The twin's (:meth:`.batch.EquilibriumBatch.reactions`): the same statics."""
        return self.play.reactions(joint, frame, part)

    def contact_forces(self, joint: str) -> Array:
        """The twin's: the same contact forces."""
        return self.play.contact_forces(joint)

    def contact_points(self, joint: str) -> tuple[str, ...]:
        return self.play.contact_points(joint)

    def drive_torques(self) -> dict[str, Array]:
        return self.play.drive_torques()

    @property
    def ok(self) -> Array:
        return self.play.ok

    @property
    def energy(self) -> Array:
        """Potential per case [J]: the play's less the springs' :math:`\\tfrac12 e^T K e`."""
        energy = np.array(self.play.energy, dtype=float)
        for name, spring in self._springs.items():
            directions, stiffnesses = elastic(self.mechanism.joints[name].clearance)
            if name in self._turns:  # K in the housing's axes: e there, G e
                coordinates = turned(self._turns[name], spring) @ directions
            else:
                coordinates = spring @ directions  # e along each deflecting direction
            energy -= 0.5 * (coordinates**2 * stiffnesses).sum(axis=1)
        return energy

    def _mechanism(self) -> Any:
        return self.mechanism


def _placements(mechanism: Mechanism, configurations: Sequence[Any] | None) -> tuple[Array, Array]:
    """Body placements (K, bodies, 3, 3), (K, bodies, 3) [m]: K = N along a trajectory, 1 at
    the nominal configuration."""
    if configurations is None:
        oMi = prepared_geometry(mechanism).configuration.oMi
        rotations = np.array([m.rotation for m in oMi])[None]
        translations = np.array([m.translation for m in oMi])[None]
        return rotations, translations
    nominal = mechanism.q_nominal
    return body_placements(mechanism, [nominal if q is None else q for q in configurations])


__all__ = ["ElasticTreeBatch", "RigidPlay", "solve_superposed"]

r"""The admissible clearance states of the small-displacement model, built from the model alone.

Written from docs/method.md section 2 (the solver's own maps are not used: this is a second
construction from the same model description, Pinocchio placements and clearance kinds). It
gives the envelope what the equilibria do not: which output directions the play bounds at all,
which ones no contact sees (free motions), and the quadratic forms of the contacts for the
optimality certificate of :mod:`.certificate`.

Unknowns: every tree joint's torsor, scaled, $T_k = Z \hat z_k$ with $Z = \mathrm{diag}(c\,I_3,
(c / L_{ref}) I_3)$ ($c$: geometric mean of the plays, $L_{ref}$: the mechanism's length scale).
Body twists add along the tree, $\xi_i = \sum_{k \in \mathrm{support}(i)} \mathrm{Ad}(oM_k C_k)
T_k$; a loop joint's torsor is $\mathrm{Ad}(oM_{C_b})^{-1} (\xi_b - \xi_a)$ at its child-side
clearance frame (section 2.3). Equalities $E \hat z = 0$: rigid components, components a drive
locks, contact points without play; $\hat z = N y$ with $N$ an orthonormal basis of their null
space. A contact point with play $j$ keeps $\lVert A_j y + o_j \rVert \le c_j$ (ball, disc) or
$\lvert a_j^T y + o_j \rvert \le c_j$ (slab), $o_j$ the nominal eccentricity of a misaligned loop
joint (section 2.4). The output point $p$ of body $b$ moves by $G_t y = v_b + \omega_b \times p$
[m] and turns by $G_r y = \omega_b$ [rad].

Free motions: $K$, an orthonormal basis of the motions $y$ that no contact sees
($A_j K = 0$ for all $j$). Their image at the output, $F = \mathrm{range}(G K)$, is a direction
along which the output moves without bound (a shaft's spin seen as a rotation); the envelope is
the bounded part, the output's deviation projected onto $F^\perp$. Its span $B$ is
$\mathrm{range}(P_{F^\perp} G)$: the directions the play bounds; the deviation has no component
off $B \oplus F$ (a planar mechanism's out-of-plane translation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from .output import Kind, Output

Matrix = npt.NDArray[np.float64]
RANK_RTOL = 1e-10  # singular values of unit rows counted in a rank (as the solver's reduction)
SPAN_RTOL = 1e-9  # an output direction moved by less than this share of the largest is not moved
ECCENTRICITY_RTOL = 1e-9  # below this share of the length scale an offset is closure round-off


@dataclass(frozen=True)
class ContactRows:
    """One contact point with play in the reduced unknowns y.

    Attributes:
        label: ``joint:point``.
        rows: $A_j$, (k, n): the selected displacement components [m] of the point per unit y.
        offset: $o_j$ [m], (k,): a misaligned housing's eccentricity at y = 0 (else zeros).
        bound: the play $c_j$ [m].
        shape: ``"norm"`` (ball, disc) or ``"abs"`` (slab, k = 1).
    """

    label: str
    rows: Matrix
    offset: Matrix
    bound: float
    shape: str


@dataclass(frozen=True)
class StateSpace:
    """The reduced admissible states of one mechanism at one configuration, for one output.

    Attributes:
        size: number of reduced unknowns n.
        contacts: the contact points with play.
        output_maps: ``"translation"`` -> $G_t$ (3, n) [m], ``"rotation"`` -> $G_r$ (3, n) [rad].
        free: $K$, (n, f): orthonormal basis of the motions no contact sees.
        scales: per kind, the deviation of a motion of the size of the play: $c$ [m] for a
            translation, $c / L_{ref}$ [rad] for a rotation.
    """

    size: int
    contacts: tuple[ContactRows, ...]
    output_maps: dict[str, Matrix]
    free: Matrix
    scales: dict[str, float]

    def free_directions(self, kind: Kind) -> Matrix:
        """Orthonormal basis (3, f) of $F$: the output directions a free motion moves."""
        return _range(self.output_maps[kind] @ self.free, self._scale(kind))

    def bounded_span(self, kind: Kind) -> Matrix:
        """Orthonormal basis (3, k) of $B$: the directions the play bounds (off $F$)."""
        free = self.free_directions(kind)
        projected = self.output_maps[kind] - free @ (free.T @ self.output_maps[kind])
        return _aligned(_range(projected, self._scale(kind)))

    def _scale(self, kind: Kind) -> float:
        """What a singular value of the output map is compared with: the larger of its own
        largest and the kind's play scale (round-off of a part that does not move stays below)."""
        return max(float(np.linalg.norm(self.output_maps[kind], 2)), self.scales[kind])

    def projected_map(self, kind: Kind, basis: Matrix) -> Matrix:
        """$B^T G$ (k, n): the output deviation in the coordinates of ``basis`` (3, k), with the
        free motions removed ($G (I - K K^T)$)."""
        g = self.output_maps[kind]
        return np.asarray(basis.T @ (g - (g @ self.free) @ self.free.T), dtype=float)


def _range(matrix: Matrix, scale: float) -> Matrix:
    """Orthonormal basis of the range of ``matrix`` (3, m): left singular vectors above
    :data:`SPAN_RTOL` times ``scale``."""
    if matrix.size == 0:
        return np.zeros((matrix.shape[0], 0))
    u, s, _ = np.linalg.svd(matrix, full_matrices=False)
    keep = s > SPAN_RTOL * scale
    return np.asarray(u[:, keep], dtype=float)


def _aligned(basis: Matrix) -> Matrix:
    """The same span with axes as near the world's as it allows: the world axes projected on
    it, largest first, orthonormalised (a planar mechanism in the x-y plane gets x and y)."""
    k = basis.shape[1]
    if k in (0, 3):
        return np.eye(3) if k == 3 else basis
    projector = basis @ basis.T
    order = np.argsort(-np.linalg.norm(projector, axis=0), kind="stable")
    out: list[Matrix] = []
    for i in order:
        v = projector[:, i].copy()
        for w in out:
            v -= (w @ v) * w
        if np.linalg.norm(v) > 1e-6:
            out.append(v / np.linalg.norm(v))
        if len(out) == k:
            break
    return np.column_stack(out)


def _null_space(rows: Matrix, n: int) -> Matrix:
    """Orthonormal basis (n, n - rank) of the null space of ``rows`` (m, n), each row scaled to
    unit norm, rank: singular values above :data:`RANK_RTOL` (of 1)."""
    if rows.shape[0] == 0:
        return np.eye(n)
    norms = np.linalg.norm(rows, axis=1)
    rows = rows[norms > 0.0] / norms[norms > 0.0, None]
    if rows.shape[0] == 0:
        return np.eye(n)
    _, s, vt = np.linalg.svd(rows)
    rank = int(np.sum(s > RANK_RTOL))
    return np.asarray(vt[rank:].T.copy(), dtype=float)


def _adjoint(placement: Any) -> Matrix:
    """Ad(M) (6, 6): a twist (v, omega) in frame M to the world origin."""
    return np.asarray(placement.action, dtype=float)


def _skew(a: Matrix) -> Matrix:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def build_state_space(mechanism: Any, configuration: Any, output: Output) -> StateSpace:
    """The :class:`StateSpace` of ``mechanism`` at ``configuration`` for ``output`` (see the
    module docstring for the equations)."""
    model = mechanism.model
    tree = sorted(mechanism.tree_joints, key=lambda j: j.joint_id)
    bounds = [
        c.bound for j in mechanism.joints.values() for c in j.clearance.contacts if c.bound > 0.0
    ]
    play = float(np.exp(np.mean(np.log(bounds)))) if bounds else 1.0
    length = float(mechanism.length_scale())
    scale = np.diag([play] * 3 + [play / length] * 3)
    n_z = 6 * len(tree)
    column = {joint.joint_id: 6 * index for index, joint in enumerate(tree)}
    twists = [np.zeros((6, n_z)) for _ in range(model.njoints)]
    equalities: list[Matrix] = []
    contact_maps: list[tuple[str, Any, Matrix, Any]] = []  # offset: pin.SE3 or None
    for joint in tree:
        i = joint.joint_id
        torsor = np.zeros((6, n_z))
        torsor[:, column[i] : column[i] + 6] = scale
        placement = configuration.oMi[i] * pin.SE3(joint.rotation, np.zeros(3))
        twists[i] = twists[model.parents[i]] + _adjoint(placement) @ torsor
        fixed = (*joint.clearance.rigid_components, *joint.locked_components)
        equalities.extend(torsor[c][None, :] for c in fixed)
        contact_maps.append((joint.name, joint.clearance, torsor, None))
    tolerance = ECCENTRICITY_RTOL * max(length, 1.0)
    for loop in mechanism.loop_joints:
        centre = configuration.oMf[loop.frame_b] * configuration.bMc[loop.name]
        a = model.frames[loop.frame_a].parentJoint
        b = model.frames[loop.frame_b].parentJoint
        torsor = np.asarray(centre.inverse().action, dtype=float) @ (twists[b] - twists[a])
        equalities.extend(torsor[c][None, :] for c in loop.clearance.rigid_components)
        offset = configuration.eccentricity(loop)
        miss = max(
            float(np.abs(offset.translation).max()),
            length * float(np.abs(pin.log3(offset.rotation)).max()),
        )
        contact_maps.append(
            (loop.name, loop.clearance, torsor, None if miss <= tolerance else offset)
        )
    with_play: list[tuple[str, Matrix, Matrix, float, str]] = []
    for name, clearance, torsor, offset in contact_maps:
        for contact in clearance.contacts:
            rows = contact.linear_rows() @ torsor
            if contact.bound == 0.0:
                equalities.append(rows)
                continue
            moved = np.zeros(len(contact.components))
            if offset is not None:
                moved = contact.displacement(offset.rotation, offset.translation)
            with_play.append((f"{name}:{contact.name}", rows, moved, contact.bound, contact.shape))
    closure = _null_space(np.vstack(equalities) if equalities else np.zeros((0, n_z)), n_z)
    contacts = tuple(
        ContactRows(label, rows @ closure, moved, bound, shape)
        for label, rows, moved, bound, shape in with_play
    )
    n = closure.shape[1]
    seen = np.vstack([c.rows / c.bound for c in contacts]) if contacts else np.zeros((0, n))
    free = _null_space(seen, n)
    twist = twists[output.body] @ closure
    translation = twist[:3] - _skew(output.position) @ twist[3:]
    return StateSpace(
        size=n,
        contacts=contacts,
        output_maps={"translation": translation, "rotation": twist[3:].copy()},
        free=free,
        scales={"translation": play, "rotation": play / length},
    )

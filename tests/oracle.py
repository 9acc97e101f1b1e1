r"""An independent formulation of the small-displacement clearance equilibrium (test-only oracle).

It shares nothing with ``clearance_pin.equilibrium`` but the model description (the Pinocchio
model, the joints' clearance frames and contact points) and the nominal configuration, and solves
the problem as stated in [Y] (README), with a generic cone solver (cvxpy + Clarabel):

- unknowns: every moving body b gets a small displacement, written as the displacement
  :math:`d_b` [m] of its frame origin :math:`o_b` and its small rotation :math:`\theta_b` [rad]
  (world axes); its spatial twist at the world origin is :math:`\xi_b = (d_b - \theta_b \times o_b,
  \theta_b)`, the ground's is zero;
- joint torsors: tree joint (parent p, child i) at its clearance frame :math:`oM_c = oM_i\, C`,
  loop joint at its child-side clearance frame :math:`C_b` (docs/method.md section 2.3, written
  here from that text: origin at ``frame_b``'s origin, the housing's axes :math:`R_a R_{loop}`,
  tilted onto the child's axis when the spin is free, turned with the child when every rotation
  is bounded, unturned for a ball) between the bodies of its two frames:
  :math:`T = \mathrm{Ad}(oM_c)^{-1} (\xi_{child} - \xi_{parent})`, with
  :math:`\mathrm{Ad}(R, t)^{-1}(v, \omega) = (R^T (v + \omega \times t),\ R^T \omega)`;
- conditions on T: rigid components and the driven joint's own motion are zero; every contact
  point r moves by :math:`V + \Omega \times r`, whose selected components, plus a misaligned
  loop joint's nominal eccentricity :math:`o = S (p_e + R_e r - r)` (:math:`(R_e, p_e) =
  C_a^{-1} C_b`, zero when it is below 1e-9 of the length scale), stay in a ball (norm) or a slab
  (abs) of radius the bound; a zero bound is an equality;
- potential :math:`\mathcal{V} = -\sum_b W_b\cdot\xi_b` with the wrench :math:`W_b = (F, p\times F
  + C)` at the world origin of every load (point forces, torques, gravity at the centres of mass).

The unknowns are scaled by a reference clearance and length only (no reduction, no elimination).
The problem is posed at the nominal configuration or at any ``q`` (``Oracle(mechanism, q)``,
``judge(mechanism, loads, q=q)``: the driven joints moved, the loops closed by the library's
``configure``, whose closure the oracle's own eccentricity measures).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import cvxpy as cp
import numpy as np
import pinocchio as pin

from clearance_pin import Gravity, PointForce, Torque

U, V, W, ALPHA, BETA, GAMMA = range(6)


def skew(a: np.ndarray) -> np.ndarray:
    """Cross-product matrix [a]x, (3, 3)."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def inverse_adjoint(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    r"""(6, 6) map of a spatial twist (v, omega) at the world origin to the frame (R, t):
    :math:`(R^T (v + \omega \times t), R^T \omega)`."""
    out = np.zeros((6, 6))
    out[:3, :3] = rotation.T
    out[:3, 3:] = -rotation.T @ skew(translation)
    out[3:, 3:] = rotation.T
    return out


def adjoint(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    r"""(6, 6) map of a twist (V, Omega) in the frame (R, t) to the world origin:
    :math:`(R V + t \times R \Omega, R \Omega)`."""
    out = np.zeros((6, 6))
    out[:3, :3] = rotation
    out[:3, 3:] = skew(translation) @ rotation
    out[3:, 3:] = rotation
    return out


def point_rows(point, components) -> np.ndarray:
    r"""Rows mapping a torsor (V, Omega) to the selected components of :math:`V + \Omega\times r`."""
    rows = np.hstack([np.eye(3), -skew(np.asarray(point, dtype=float))])
    return rows[list(components)]


def fixed_rows(joint) -> list:
    """Rows (6,) of the torsor components a tree joint fixes: rigid, locked by the drive, or held
    by a contact point without clearance."""
    fixed = [np.eye(6)[c] for c in (*joint.clearance.rigid_components, *joint.locked_components)]
    fixed += [
        row
        for c in joint.clearance.contacts
        if c.bound == 0.0
        for row in point_rows(c.point, c.components)
    ]
    return fixed


@dataclass
class OracleContact:
    r"""One contact point: its rows on the unknowns z (k, n), bound [m], shape, and its
    selected displacement at z = 0 (k,) [m] (a misaligned housing's eccentricity, else 0): the
    condition is :math:`\|o + \mathrm{rows}\, z\| \le` bound."""

    label: str
    rows: np.ndarray
    bound: float
    shape: str
    offset: np.ndarray | None = None

    def __post_init__(self):
        if self.offset is None:
            self.offset = np.zeros(self.rows.shape[0])

    def image(self, z: np.ndarray) -> np.ndarray:
        """Selected displacement components [m] of the contact point at z."""
        return self.offset + self.rows @ z

    def size(self, z: np.ndarray) -> float:
        """Norm (disc) or absolute value (slab) of :meth:`image` [m]."""
        image = self.image(z)
        return float(np.linalg.norm(image)) if self.shape == "norm" else abs(float(image[0]))


def minimal_rotation(v: np.ndarray) -> np.ndarray:
    """The rotation of least angle taking the x axis to the unit vector ``v`` (Rodrigues)."""
    v = np.asarray(v, dtype=float) / np.linalg.norm(v)
    axis = np.cross([1.0, 0.0, 0.0], v)
    s, c = float(np.linalg.norm(axis)), float(v[0])
    if s < 1e-300:
        return np.eye(3) if c > 0 else np.diag([-1.0, -1.0, 1.0])
    k = skew(axis / s)
    return np.eye(3) + s * k + (1.0 - c) * k @ k


def loop_clearance_frames(loop, oMa: pin.SE3, oMb: pin.SE3) -> tuple[pin.SE3, pin.SE3]:
    """World placements (C_a, C_b) of a loop joint's two clearance frames, written from
    docs/method.md section 2.3: C_b at ``frame_b``'s origin with the housing's axes
    :math:`R_c = R_a R_{loop}`, tilted onto the child's own axis when the kind leaves the spin
    free, turned entirely with the child when every rotation is bounded, unturned for a ball;
    C_a with the axes :math:`R_c`, at the foot of :math:`p_b` on the housing's axis when the kind
    slides (u free), at :math:`p_a` otherwise."""
    free = set(loop.clearance.free_components)
    housing = oMa.rotation @ loop.rotation
    axis = housing[:, 0]
    p_a, p_b = oMa.translation, oMb.translation
    origin = p_a + axis * float(axis @ (p_b - p_a)) if U in free else p_a.copy()
    child = housing.T @ oMb.rotation @ loop.rotation  # the child's axes in the housing's
    if {ALPHA, BETA, GAMMA} <= free:
        turn = np.eye(3)
    elif ALPHA in free:
        turn = minimal_rotation(child[:, 0])
    else:
        turn = child
    return pin.SE3(housing, origin), pin.SE3(housing @ turn, p_b.copy())


@dataclass
class OracleResult:
    """The oracle's answer.

    Attributes:
        status: ``"optimal"``, ``"unbounded"``, ``"indeterminate"`` (no load works) or the cvxpy
            status when the solve failed. ``"unbounded"`` with solver_status ``"no bounded
            motion"``: every admissible motion is free and more than 1e-12 of the load works
            along them.
        energy: optimal potential [J] (nan unless optimal).
        twists: spatial twist (v, omega) at the world origin per Pinocchio joint, (njoints, 6).
        free_fraction: share of the load working along motions that no condition bounds.
        active: labels of the contacts carrying load (positive multiplier).
        solver_status: cvxpy's status.
        polished: the Newton polish of the KKT system on the active set was accepted (the answer
            is then exact to round-off; otherwise it has the interior-point accuracy).
    """

    status: str
    energy: float = float("nan")
    twists: np.ndarray | None = None
    free_fraction: float = 0.0
    active: tuple = ()
    solver_status: str = ""
    polished: bool = False


class Oracle:
    """The small-displacement problem of ``mechanism`` at its nominal configuration (or ``q``)."""

    def __init__(self, mechanism, q=None):
        self.mechanism = mechanism
        model = mechanism.model
        self.model = model
        data = model.createData()
        self.q = mechanism.configure(q).q  # the closed nominal configuration (model definition)
        pin.framesForwardKinematics(model, data, self.q)
        self.oMi = [m.copy() for m in data.oMi]
        self.oMf = [m.copy() for m in data.oMf]
        self.nb = model.njoints - 1
        self.n = 6 * self.nb
        bounds = [
            c.bound
            for j in mechanism.joints.values()
            for c in j.clearance.contacts
            if c.bound > 0.0
        ]
        self.c_ref = float(np.exp(np.mean(np.log(bounds)))) if bounds else 1.0
        origins = [np.linalg.norm(m.translation) for m in self.oMi]
        self.l_ref = max(origins + [j.clearance.length for j in mechanism.joints.values()]) or 1.0
        # z -> spatial twists: xi_b = (d_b - theta_b x o_b, theta_b), d = c_ref z_d, theta = c_ref/L z_t
        self.twist_map = np.zeros((model.njoints, 6, self.n))
        for b in range(1, model.njoints):
            block = np.zeros((6, 6))
            block[:3, :3] = self.c_ref * np.eye(3)
            block[:3, 3:] = skew(self.oMi[b].translation) * (self.c_ref / self.l_ref)
            block[3:, 3:] = (self.c_ref / self.l_ref) * np.eye(3)
            self.twist_map[b][:, 6 * (b - 1) : 6 * b] = block
        self.torsor_maps: dict[str, np.ndarray] = {}
        self.equalities: list[np.ndarray] = []
        self._equality_is_loop: list[bool] = []
        self.contacts: list[OracleContact] = []
        for joint in mechanism.tree_joints:
            i = joint.joint_id
            oMc = self.oMi[i] * pin.SE3(joint.rotation, np.zeros(3))
            self._add_joint(
                joint, oMc, model.parents[i], i, locked=joint.locked_components, loop=False
            )
        self.loop_centres: dict[str, pin.SE3] = {}
        self.eccentricity: dict[str, pin.SE3] = {}
        for loop in mechanism.loop_joints:
            oMc, relative = self._loop_frame(loop)
            a = model.frames[loop.frame_a].parentJoint
            b = model.frames[loop.frame_b].parentJoint
            self._add_joint(loop, oMc, a, b, locked=(), loop=True, eccentricity=relative)
        self.equality_matrix = (
            np.vstack(self.equalities) if self.equalities else np.zeros((0, self.n))
        )
        self.ambiguous_free = False  # set by solve()

    def _loop_frame(self, loop) -> tuple[pin.SE3, pin.SE3]:
        """(world placement of the loop joint's torsor frame C_b, its eccentricity C_a^-1 C_b).

        A mismatch of at most 1e-9 of the length scale (at least 1 m) is closure round-off, not
        an eccentricity (docs/method.md section 2.4): the torsor is then taken at C_a."""
        parent, child = loop_clearance_frames(loop, self.oMf[loop.frame_a], self.oMf[loop.frame_b])
        relative = parent.actInv(child)
        length = max(self.mechanism.length_scale(), 1.0)
        miss = max(
            float(np.abs(relative.translation).max()),
            length * float(np.abs(pin.log3(relative.rotation)).max()),
        )
        if miss <= 1e-9 * length:
            child, relative = parent, pin.SE3.Identity()
        self.loop_centres[loop.name] = child
        self.eccentricity[loop.name] = relative
        return child, relative

    def _add_joint(
        self, joint, oMc, parent_body: int, child_body: int, locked, loop: bool, eccentricity=None
    ) -> None:
        adjoint = inverse_adjoint(oMc.rotation, oMc.translation)
        torsor = adjoint @ (self.twist_map[child_body] - self.twist_map[parent_body])
        self.torsor_maps[joint.name] = torsor
        clearance = joint.clearance
        for component in (*clearance.rigid_components, *locked):
            self.equalities.append(torsor[component][None, :])
            self._equality_is_loop.append(loop)
        for contact in clearance.contacts:
            rows = point_rows(contact.point, contact.components) @ torsor
            if contact.bound == 0.0:
                self.equalities.append(rows)
                self._equality_is_loop.append(loop)
            else:
                offset = None
                if eccentricity is not None:
                    r = np.asarray(contact.point, dtype=float)
                    moved = eccentricity.translation + eccentricity.rotation @ r - r
                    offset = moved[list(contact.components)]
                self.contacts.append(
                    OracleContact(
                        f"{joint.name}:{contact.name}", rows, contact.bound, contact.shape, offset
                    )
                )

    # -- loads --------------------------------------------------------------------------------
    def wrenches(self, loads) -> np.ndarray:
        """Wrench (F, M) at the world origin per Pinocchio joint (body), (njoints, 6) [N, N m]."""
        model = self.model
        out = np.zeros((model.njoints, 6))
        for load in loads:
            if isinstance(load, Gravity):
                for b in range(1, model.njoints):
                    inertia = model.inertias[b]
                    if inertia.mass > 0.0:
                        point = self.oMi[b].act(inertia.lever)
                        force = inertia.mass * np.asarray(load.acceleration)
                        out[b] += np.concatenate([force, np.cross(point, force)])
                continue
            frame_id = model.getFrameId(load.link, pin.FrameType.BODY)
            body = model.frames[frame_id].parentJoint
            if isinstance(load, PointForce):
                point = self.oMf[frame_id].act(np.asarray(load.point, dtype=float))
                force = np.asarray(load.force, dtype=float)
                out[body] += np.concatenate([force, np.cross(point, force)])
            elif isinstance(load, Torque):
                out[body, 3:] += np.asarray(load.torque, dtype=float)
        out[0] = 0.0  # the ground does not move
        return out

    def gradient(self, loads) -> np.ndarray:
        """g with potential = g . z, (n,)."""
        wrenches = self.wrenches(loads)
        return -np.einsum("bi,bin->n", wrenches, self.twist_map)

    def default_loads(self, gravity=None):
        """The loads a default ``mechanism.solve()`` applies."""
        return self.mechanism.resolve_loads(None, gravity)

    # -- analysis -----------------------------------------------------------------------------
    def closure_basis(self) -> np.ndarray:
        """Orthonormal basis (n, r) of the motions that keep every equality (SVD)."""
        if self.equality_matrix.shape[0] == 0:
            return np.eye(self.n)
        _, s, vt = np.linalg.svd(self.equality_matrix)
        rank = int(np.sum(s > 1e-12 * s[0])) if s.size and s[0] > 0 else 0
        return vt[rank:].T

    def tree_is_rigid(self) -> bool:
        """Whether no tree joint allows any motion (every component rigid, locked or held)."""
        for joint in self.mechanism.tree_joints:
            fixed = fixed_rows(joint)
            if not fixed or np.linalg.matrix_rank(np.array(fixed)) < 6:
                return False
        return True

    def roundoff_closure(self) -> bool:
        """Whether the rank of the loop-closure conditions is ambiguous.

        Written in the tree joints' own torsor coordinates (each joint's admissible components,
        scaled by the reference clearance), the loop joints' equality rows have a singular value
        between 0 and 1e-9: a condition that holds for some motion up to round-off (coaxial joints
        placed through rotated frames) or up to a tiny misalignment. Whether that motion is
        blocked then depends on a rank threshold; clearance_pin takes round-off rows as
        constraints (known issue, see test_stability.py), so such cases are not judged.
        """
        model = self.model
        twist = {0: np.zeros((6, 0))}
        mechanism = self.mechanism
        by_id = {joint.joint_id: joint for joint in mechanism.tree_joints}
        blocks = []
        for i in range(1, model.njoints):
            joint = by_id[i]
            fixed = fixed_rows(joint)
            if fixed:
                _, sv, vt = np.linalg.svd(np.array(fixed))
                rank = int(np.sum(sv > 1e-12 * sv[0]))
                basis = vt[rank:].T
            else:
                basis = np.eye(6)
            units = np.where(
                np.abs(basis[:3]).sum(axis=0) >= np.abs(basis[3:]).sum(axis=0),
                self.c_ref,
                self.c_ref / self.l_ref,
            )
            oMc = self.oMi[i] * pin.SE3(joint.rotation, np.zeros(3))
            blocks.append(
                (i, model.parents[i], adjoint(oMc.rotation, oMc.translation) @ basis * units)
            )
        total = sum(b[2].shape[1] for b in blocks)
        start = 0
        for i, parent, block in blocks:
            twist[i] = np.zeros((6, total))
            twist[i][:, : twist[parent].shape[1]] = twist[parent]
            twist[i][:, start : start + block.shape[1]] += block
            start += block.shape[1]
        for i, value in list(twist.items()):
            padded = np.zeros((6, total))
            padded[:, : value.shape[1]] = value
            twist[i] = padded
        rows = []
        for loop in mechanism.loop_joints:
            oMc = self.loop_centres[loop.name]
            a = model.frames[loop.frame_a].parentJoint
            b = model.frames[loop.frame_b].parentJoint
            torsor = inverse_adjoint(oMc.rotation, oMc.translation) @ (twist[b] - twist[a])
            rows += [torsor[c] for c in loop.clearance.rigid_components]
            rows += [
                row
                for c in loop.clearance.contacts
                if c.bound == 0.0
                for row in point_rows(c.point, c.components) @ torsor
            ]
        if not rows or total == 0:
            return False
        singular = np.linalg.svd(np.array(rows) / self.c_ref, compute_uv=False)
        return bool(np.any((singular > 0.0) & (singular < 1e-9)))

    def free_motions(self) -> np.ndarray:
        """Basis (n, f) in z of the motions that no condition sees (orthonormal)."""
        rows = [self.equality_matrix] + [c.rows / c.bound * self.c_ref for c in self.contacts]
        matrix = np.vstack(rows) if rows else np.zeros((0, self.n))
        if matrix.shape[0] == 0:
            return np.eye(self.n)
        _, s, vt = np.linalg.svd(matrix)
        rank = int(np.sum(s > 1e-10 * s[0])) if s.size and s[0] > 0 else 0
        return vt[rank:].T

    def solve(self, loads, tol: float = 1e-12) -> OracleResult:
        """Minimise the potential over the admissible small displacements."""
        g = self.gradient(loads)
        reference = float(np.linalg.norm(g))
        free = self.free_motions()
        fraction = float(np.linalg.norm(free.T @ g) / reference) if reference > 0 else 0.0
        if reference == 0.0:
            return OracleResult("indeterminate", 0.0, np.zeros((self.model.njoints, 6)))
        # equalities eliminated exactly (z = N w, N an orthonormal basis of null(E)), and the
        # motions that no contact sees left out (the load is orthogonal to them or unbounded)
        basis = self.closure_basis()
        if self.contacts:
            seen = np.vstack([c.rows / c.bound for c in self.contacts]) @ basis
            _, s, vt = np.linalg.svd(seen, full_matrices=True)
            # relative rank, and an absolute floor: a motion that moves the contacts by 1e-13 of
            # their play per reference clearance is seen by round-off only (free_motions counts
            # it as free; kept here, Clarabel called it unbounded, stability example 1601)
            rank = int(np.sum(s > max(1e-10 * s[0], 1e-13))) if s.size and s[0] > 0 else 0
            basis = basis @ vt[:rank].T
            # a motion that the contacts see only weakly: whether it is free is a rank decision
            self.ambiguous_free = bool(s.size and np.any((s > 1e-14 * s[0]) & (s < 1e-8 * s[0])))
        # the objective normalised by the load's work on the motions left (not by the whole load,
        # most of which rigid joints may carry)
        working = float(np.linalg.norm(basis.T @ g))
        if working <= 1e-13 * reference and fraction <= 1e-13:
            return OracleResult("indeterminate", 0.0, np.zeros((self.model.njoints, 6)), fraction)
        if basis.shape[1] == 0:  # no bounded motion is left: the load works along free ones only
            if fraction <= 1e-12:  # round-off of the whole load
                return OracleResult(
                    "indeterminate", 0.0, np.zeros((self.model.njoints, 6)), fraction
                )
            return OracleResult(
                "unbounded", free_fraction=fraction, solver_status="no bounded motion"
            )
        reference = working or reference
        w = cp.Variable(basis.shape[1])
        z = basis @ w
        constraints = []
        cones = []
        for contact in self.contacts:
            rows = contact.rows @ basis / contact.bound  # dimensionless: ||rows w + o|| <= 1
            offset = contact.offset / contact.bound
            if contact.shape == "norm":
                cones.append(cp.norm(rows @ w + offset, 2) <= 1.0)
            else:
                cones.append(cp.abs(rows[0] @ w + offset[0]) <= 1.0)
        constraints += cones
        problem = cp.Problem(cp.Minimize((g / reference) @ z), constraints)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # "Solution may be inaccurate": polished below
                problem.solve(
                    solver="CLARABEL",
                    tol_gap_abs=tol,
                    tol_gap_rel=tol,
                    tol_feas=tol,
                    tol_ktratio=1e-10,
                    max_iter=400,
                )
        except cp.error.SolverError as exc:
            return OracleResult(f"solver error: {exc}", free_fraction=fraction)
        status = problem.status
        if status in (cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE):
            return OracleResult("unbounded", free_fraction=fraction, solver_status=status)
        if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or w.value is None:
            return OracleResult(str(status), free_fraction=fraction, solver_status=status)
        matrices = [contact.rows @ basis / contact.bound for contact in self.contacts]
        duals = np.array(
            [
                float(np.abs(np.atleast_1d(c.dual_value)).max())
                if c.dual_value is not None
                else 0.0
                for c in cones
            ]
        )
        objective = basis.T @ g / reference
        w_value, multipliers, polished = polish(
            objective,
            matrices,
            [c.shape for c in self.contacts],
            w.value,
            duals,
            offsets=[c.offset / c.bound for c in self.contacts],
        )
        z_value = basis @ w_value
        active = tuple(
            c.label
            for c, lam in zip(self.contacts, multipliers)
            if lam > 1e-9 * max(multipliers.max(initial=0.0), 1e-300)
        )
        return OracleResult(
            "optimal", float(g @ z_value), self.twists(z_value), fraction, active, status, polished
        )

    # -- evaluation of any answer given as body twists ---------------------------------------
    def twists(self, z: np.ndarray) -> np.ndarray:
        """Spatial twists per Pinocchio joint (njoints, 6) from z."""
        return np.einsum("bin,n->bi", self.twist_map, z)

    def z_from_twists(self, twists: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`twists` (least squares; exact for twists of this model)."""
        stacked = self.twist_map[1:].reshape(-1, self.n)
        return np.linalg.lstsq(stacked, np.asarray(twists)[1:].reshape(-1), rcond=None)[0]

    def energy_of(self, twists: np.ndarray, loads) -> float:
        """Potential [J] of the loads at the given body twists."""
        return -float(np.sum(self.wrenches(loads) * np.asarray(twists)))

    def torsors_of(self, twists: np.ndarray) -> dict[str, np.ndarray]:
        """Joint torsors (clearance frames) at the given body twists."""
        z = self.z_from_twists(twists)
        return {name: m @ z for name, m in self.torsor_maps.items()}

    def violations_of(self, twists: np.ndarray) -> tuple[float, float]:
        """(largest contact violation / its bound, largest equality residual / c_ref)."""
        z = self.z_from_twists(twists)
        worst = 0.0
        for contact in self.contacts:
            worst = max(worst, (contact.size(z) - contact.bound) / contact.bound)
        equality = float(np.abs(self.equality_matrix @ z).max(initial=0.0)) / self.c_ref
        return worst, equality

    def gaps_of(self, twists: np.ndarray) -> dict[str, float]:
        """Remaining play / bound per contact label at the given twists."""
        z = self.z_from_twists(twists)
        out = {}
        for contact in self.contacts:
            out[contact.label] = (contact.bound - contact.size(z)) / contact.bound
        return out

    def loaded_difference(self, twists_a: np.ndarray, twists_b: np.ndarray) -> float:
        """Largest torsor difference between two answers once the free motions are projected out,
        as max(|dV|, |dOmega| L_ref) over joints, relative to the largest clearance."""
        difference = self.z_from_twists(twists_a) - self.z_from_twists(twists_b)
        free = self.free_motions()
        difference = difference - free @ (free.T @ difference)
        c_max = max((c.bound for c in self.contacts), default=self.c_ref)
        worst = 0.0
        for m in self.torsor_maps.values():
            t = m @ difference
            worst = max(worst, float(np.abs(t[:3]).max()), float(np.abs(t[3:]).max()) * self.l_ref)
        return worst / c_max

    def statics_of(self, equilibrium, loads) -> float:
        r"""Independent virtual-work check of the reported contact forces: for every admissible
        motion z (equalities kept), :math:`W\cdot\xi(z) + \sum_j f_j\cdot(S_j T_j(z)) = 0`;
        returns the residual (rigid reactions fitted) relative to the load's size."""
        work, _, reference = self._stationarity(equilibrium, loads)
        return float(np.linalg.norm(work) / reference)

    def _stationarity(self, equilibrium, loads):
        """(unbalanced virtual work per unit z (n,), fitted equality reactions nu, |load|)."""
        g = -self.gradient(loads)  # the load's virtual work per unit z
        work = g.copy()
        forces = {c.label: c for c in equilibrium.contacts}
        for contact in self.contacts:
            reported = forces[contact.label]
            components = self._components(contact.label)
            work += contact.rows.T @ np.asarray(reported.force)[list(components)]
        reference = float(np.linalg.norm(g)) or 1.0
        nu = np.zeros(self.equality_matrix.shape[0])
        if self.equality_matrix.shape[0]:
            nu = np.linalg.lstsq(self.equality_matrix.T, work, rcond=None)[0]
            work = work - self.equality_matrix.T @ nu
        return work, nu, reference

    def energy_gap_bound(self, equilibrium, loads, twists) -> float:
        r"""How much lower [J] than the library's answer the potential of another answer (body
        twists) may be, given how well each keeps the equalities.

        From the library's KKT point (z_l, contact multipliers, reactions nu, unbalanced work
        r): for any z that keeps the contacts, convexity of the Lagrangian gives
        :math:`E(z) \ge E(z_l) - |\nu\cdot E(z - z_l)| - |r\cdot(z - z_l)|`. The first term is
        the work of the equality reactions on the closure residuals of the two answers: with
        large reactions (a load mostly carried by rigid directions) round-off of the closure
        alone moves the energy at the 1e-8 level of its small working part.
        """
        work, nu, _ = self._stationarity(equilibrium, loads)
        step = self.z_from_twists(twists) - self.z_from_twists(equilibrium.body_twists)
        closure = abs(float(nu @ (self.equality_matrix @ step))) if nu.size else 0.0
        return closure + abs(float(work @ step))

    def certificate_of(self, equilibrium, loads) -> dict[str, float]:
        r"""KKT certificate of a library answer in this formulation (sufficient for optimality:
        the problem is convex). Residuals, each dimensionless:

        - ``violation``, ``equality``: primal feasibility of the answer (:meth:`violations_of`);
        - ``statics``: stationarity, the reported contact forces balancing the load with the
          equality reactions fitted (:meth:`statics_of`);
        - ``complementarity``: largest force, relative to the largest one, at a contact whose gap
          exceeds 1e-9 of its bound;
        - ``dual``: largest misalignment 1 - cos between a contact force and the push back
          against the contact's displacement (a disc: the force along -delta; a slab: opposite
          sign), for the forces above 1e-9 of the largest.

        When all are below 1e-9 the answer is an optimum of this problem, whatever the oracle's
        own interior-point answer is (flat optima, unpolished oracle).
        """
        z = self.z_from_twists(equilibrium.body_twists)
        violation, equality = self.violations_of(equilibrium.body_twists)
        forces = {c.label: c for c in equilibrium.contacts}
        selected = {
            c.label: np.asarray(forces[c.label].force)[list(self._components(c.label))]
            for c in self.contacts
        }
        largest = max((float(np.linalg.norm(f)) for f in selected.values()), default=0.0)
        complementarity = dual = 0.0
        for contact in self.contacts:
            force = selected[contact.label]
            size = float(np.linalg.norm(force))
            if largest == 0.0 or size <= 1e-9 * largest:
                continue
            delta = contact.image(z)
            reach = float(np.linalg.norm(delta))
            if reach < contact.bound * (1.0 - 1e-9):
                complementarity = max(complementarity, size / largest)
                continue
            dual = max(dual, 1.0 + float(force @ delta) / (size * reach))
        return {
            "violation": max(violation, 0.0),
            "equality": equality,
            "statics": self.statics_of(equilibrium, loads),
            "complementarity": complementarity,
            "dual": dual,
        }

    def _components(self, label: str):
        joint_name, point_name = label.split(":", 1)
        for contact in self.mechanism.joint(joint_name).clearance.contacts:
            if contact.name == point_name:
                return contact.components
        raise KeyError(label)


def compare(equilibrium, oracle: Oracle, result: OracleResult, loads) -> dict[str, float]:
    """Errors of a clearance_pin equilibrium against the oracle (all dimensionless).

    ``energy``: |E_lib - E_oracle| / |E_oracle|; ``energy_consistency``: the library's reported
    energy against the potential of its own displacement; ``violation``: largest penetration /
    bound at the library's displacement; ``equality``: closure residual / c_ref; ``torsor_report``:
    reported torsors against those of the library's twists, relative to the largest clearance;
    ``torsor``: library against oracle torsors, free motions projected out; ``statics``:
    virtual-work residual of the reported contact forces.
    """
    twists = equilibrium.body_twists
    scale = abs(result.energy) or 1.0
    c_max = max((c.bound for c in oracle.contacts), default=oracle.c_ref)
    own = oracle.torsors_of(twists)
    report = 0.0
    for name, torsor in own.items():
        t = equilibrium.torsors[name] - torsor
        report = max(report, float(np.abs(t[:3]).max()), float(np.abs(t[3:]).max()) * oracle.l_ref)
    violation, equality = oracle.violations_of(twists)
    return {
        "energy": abs(equilibrium.energy - result.energy) / scale,
        "energy_consistency": abs(equilibrium.energy - oracle.energy_of(twists, loads)) / scale,
        "violation": violation,
        "equality": equality,
        "torsor_report": report / c_max,
        "torsor": oracle.loaded_difference(twists, result.twists),
        "statics": oracle.statics_of(equilibrium, loads),
    }


def bounded_loads(oracle: Oracle, loads) -> list:
    """The loads with their component along the free motions removed (so an equilibrium exists),
    as one force at each body's frame origin and one torque per body (world axes)."""
    g = oracle.gradient(loads)
    free = oracle.free_motions()
    raw = float(np.linalg.norm(g))
    g = g - free @ (free.T @ g)
    model = oracle.model
    out = []
    if float(np.linalg.norm(g)) <= 1e-12 * raw:
        return out  # nothing but round-off is left: no load
    for b in range(1, model.njoints):
        block = oracle.twist_map[b][:, 6 * (b - 1) : 6 * b]
        wrench = -np.linalg.solve(block.T, g[6 * (b - 1) : 6 * b])
        if not np.any(wrench):
            continue
        force, moment = wrench[:3], wrench[3:]
        torque = moment - np.cross(oracle.oMi[b].translation, force)
        link = next(
            f.name
            for f in model.frames
            if f.type == pin.FrameType.BODY and f.parentJoint == b and f.placement.isIdentity()
        )
        out.append(PointForce(link, force, (0.0, 0.0, 0.0)))
        out.append(Torque(link, torque))
    return out


def polish(objective, matrices, shapes, w, duals, iterations: int = 40, offsets=None):
    r"""Newton's method on the KKT system of the contacts in touch, from an interior-point answer.

    Problem: :math:`\min f^T w` s.t. :math:`\phi_j = \|A_j w + o_j\|^2 - 1 \le 0` (norm) or
    :math:`\phi_j = s_j (a_j^T w + o_j) - 1 \le 0` (slab, side :math:`s_j`; offsets o_j: 0 by
    default). On the active set A, solve
    :math:`f + \sum_A \lambda_j \nabla\phi_j = 0,\ \phi_A = 0` (least-squares steps: motions
    that nothing sees and flat optima stay where the interior point put them).

    Returns:
        (w, multipliers per contact, accepted).
    """
    count = len(matrices)
    multipliers = np.zeros(count)
    if count == 0 or w.size == 0:
        return w, multipliers, False
    if offsets is None:
        offsets = [np.zeros(m.shape[0]) for m in matrices]
    image = [m @ w + o for m, o in zip(matrices, offsets)]
    phi = np.array(
        [im @ im - 1.0 if sh == "norm" else abs(im[0]) - 1.0 for im, sh in zip(image, shapes)]
    )
    signs = np.array([1.0 if sh == "norm" or im[0] >= 0 else -1.0 for im, sh in zip(image, shapes)])
    largest = max(float(duals.max(initial=0.0)), 1e-300)
    active = np.flatnonzero((phi > -1e-5) & (duals > 1e-7 * largest))
    for _ in range(4):
        if active.size == 0:
            return w, multipliers, False
        result = _newton(
            objective,
            matrices,
            shapes,
            signs,
            active,
            w.copy(),
            duals[active] / 2.0,
            iterations,
            offsets,
        )
        if result is None:
            return w, multipliers, False
        w_new, lam = result
        if np.any(lam < -1e-12):
            active = active[lam >= -1e-12]
            continue
        image = [m @ w_new + o for m, o in zip(matrices, offsets)]
        phi = np.array(
            [im @ im - 1.0 if sh == "norm" else abs(im[0]) - 1.0 for im, sh in zip(image, shapes)]
        )
        if np.any(phi > 1e-12):
            active = np.union1d(active, np.flatnonzero(phi > 1e-12))
            signs = np.array(
                [1.0 if sh == "norm" or im[0] >= 0 else -1.0 for im, sh in zip(image, shapes)]
            )
            continue
        multipliers[active] = np.maximum(lam, 0.0)
        return w_new, multipliers, True
    return w, multipliers, False


def _newton(objective, matrices, shapes, signs, active, w, lam, iterations, offsets):
    size = w.size
    for _ in range(iterations):
        gradients, values = [], []
        hessian = np.zeros((size, size))
        for k, j in enumerate(active):
            m = matrices[j]
            if shapes[j] == "norm":
                image = m @ w + offsets[j]
                gradients.append(2.0 * m.T @ image)
                values.append(image @ image - 1.0)
                hessian += 2.0 * lam[k] * m.T @ m
            else:
                gradients.append(signs[j] * m[0])
                values.append(signs[j] * (m[0] @ w + offsets[j][0]) - 1.0)
        jac = np.array(gradients).reshape(len(active), size)
        residual = np.concatenate([objective + jac.T @ lam, values])
        if np.abs(residual).max() < 1e-15:
            return w, lam
        kkt = np.block([[hessian, jac.T], [jac, np.zeros((len(active), len(active)))]])
        step = np.linalg.lstsq(kkt, -residual, rcond=1e-14)[0]
        w = w + step[:size]
        lam = lam + step[size:]
    return (w, lam) if np.abs(residual).max() < 1e-12 else None


# -- judging clearance_pin against the oracle ------------------------------------------------------
TOLERANCES = {
    "energy": 1e-8,
    "energy_consistency": 1e-10,
    "violation": 1e-9,
    "equality": 1e-9,
    "torsor_report": 1e-7,
    "torsor": 1e-7,
    "statics": 1e-9,
}


#: docs/method.md section 3.1 step 3: clearance_pin answers (no UnboundedLoadError) when the load's
#: component along the motions that nothing blocks is at most this share of the load
LIBRARY_UNBOUNDED_SHARE = 1e-9


@dataclass
class Verdict:
    """Outcome of one comparison: ``kind`` (agree, agree-flat, agree-energy, unbounded,
    indeterminate, diagnosed, no-work-unbounded, no-work-moved, known-below-unbounded-threshold,
    FAIL-...) and the errors measured."""

    kind: str
    errors: dict
    detail: str = ""

    @property
    def failed(self) -> bool:
        return self.kind.startswith("FAIL")


def judge(mechanism, loads, q=None) -> Verdict:
    """Solve ``loads`` (resolved: gravity included) with clearance_pin and with the oracle, at
    the nominal configuration or at ``q`` (driven joints moved; both sides close the loops from
    it), and classify the outcome. Never raises for clearance_pin's own errors; anything else
    propagates.

    ``known-below-unbounded-threshold``: the load works along a motion that nothing blocks, so
    there is no equilibrium (the oracle: ``unbounded``, no bounded motion left), but that part is
    at most :data:`LIBRARY_UNBOUNDED_SHARE` of the load, below which clearance_pin's documented
    unbounded-load test answers instead (docs/method.md section 3.1 step 3); its answer must then
    list the motion as free and move nothing. ``errors["free_fraction"]`` is the share. Not round-off
    in general (stability example 1601: an explicit 2.2e-8 N force along a free slide, 3e-10
    of a 56 N load): a known limitation, not an agreement."""
    from clearance_pin import ClearancePinError, LoadError, SolverError, UnboundedLoadError

    oracle = Oracle(mechanism, q)
    g = oracle.gradient(loads)
    basis = oracle.closure_basis()
    scale_g = float(np.linalg.norm(g))
    work = float(np.linalg.norm(basis.T @ g)) / scale_g if scale_g > 0 else 0.0
    result = oracle.solve(loads)
    c_max = max((c.bound for c in oracle.contacts), default=oracle.c_ref)
    tiny = result.status == "optimal" and abs(result.energy) < 1e-9 * scale_g * c_max / oracle.c_ref
    # the load does no work on any admissible motion (up to round-off)
    no_work = work < 1e-9 or tiny
    roundoff = oracle.roundoff_closure()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            equilibrium = mechanism.solve(loads=loads, gravity=False, q=q)
    except ValueError as exc:
        if isinstance(exc, LoadError):
            # loads beyond what double precision carries (a subnormal torque hypothesis drew):
            # refused by design (docs/model-format.md), nothing to compare
            return Verdict("refused-load", {}, str(exc))
        if not isinstance(exc, ClearancePinError) and oracle.tree_is_rigid():
            return Verdict("known-no-motion-crash", {}, f"{type(exc).__name__}: {exc}")
        raise
    except UnboundedLoadError as exc:
        if result.status == "unbounded" or result.free_fraction > 1e-9:
            return Verdict("unbounded", {}, str(exc))
        if no_work or result.free_fraction < 1e-12:
            # the component along the free motion is round-off of the whole load (known issue:
            # the library compares it with the part of the load that works, not with the load)
            return Verdict("no-work-unbounded", {"work": work}, str(exc))
        if roundoff:
            return Verdict(
                "ambiguous-closure",
                {"free_fraction": result.free_fraction, "library_fraction": exc.fraction},
                str(exc),
            )
        if result.status == "optimal":
            reach = oracle.loaded_difference(result.twists, np.zeros_like(result.twists))
            if reach > 1e2 or max(oracle.violations_of(result.twists)) > 1e-9:
                # bounded only by a lever 100 times the play (or not accurately): the motion is
                # free for practical purposes, and a diagnosis is the useful answer
                return Verdict("weakly-bounded-unbounded", {"reach": reach}, str(exc))
        return Verdict(
            "FAIL-unbounded",
            {"free_fraction": result.free_fraction, "library_fraction": exc.fraction},
            str(exc),
        )
    except SolverError as exc:
        return Verdict("diagnosed", {}, str(exc))
    except ClearancePinError as exc:
        return Verdict("FAIL-error", {}, f"{type(exc).__name__}: {exc}")
    if result.status == "unbounded" or result.free_fraction > 1e-6:
        moved = max((float(np.abs(t).max()) for t in equilibrium.torsors.values()), default=0.0)
        if (
            result.solver_status == "no bounded motion"
            and result.free_fraction <= LIBRARY_UNBOUNDED_SHARE
            and equilibrium.free_motions
            and moved == 0.0
        ):
            return Verdict(
                "known-below-unbounded-threshold",
                {"free_fraction": result.free_fraction},
                f"{result.free_fraction:.3e} of the load works along {equilibrium.free_motions}; "
                f"clearance_pin answered {equilibrium.status!r} (its threshold "
                f"{LIBRARY_UNBOUNDED_SHARE:g}), the oracle finds no equilibrium",
            )
        return Verdict(
            "FAIL-answered-unbounded", {"free_fraction": result.free_fraction}, equilibrium.status
        )
    if no_work or result.status == "indeterminate":
        moved = max((float(np.abs(t).max()) for t in equilibrium.torsors.values()), default=0.0)
        if equilibrium.status == "indeterminate" and moved == 0.0:
            return Verdict("indeterminate", {})
        if not no_work and roundoff:
            return Verdict("ambiguous-closure", {"work": work, "moved": moved})
        return Verdict("no-work-moved", {"work": work, "moved": moved}, equilibrium.status)
    if result.status != "optimal":
        return Verdict("oracle-failed", {}, result.status)
    errors = compare(equilibrium, oracle, result, loads)
    errors["library_statics"] = equilibrium.residuals.get("statics", 0.0)
    flat = any("bounded but not loaded" in f for f in equilibrium.free_motions)
    # the part of the load that works on the admissible motions is known to round-off of the
    # whole load only: relative errors of eps / work are the conditioning of the question itself
    widen = max(1.0, 1e-16 / max(work, 1e-300) / 1e-8)
    tolerances = {
        k: tol * (widen if k in ("energy", "torsor") else 1.0) for k, tol in TOLERANCES.items()
    }
    # the library's own statics residual subtracts the fitted loop reactions: its round-off grows
    # as 1 / closure conditioning, as the library's KKT acceptance does (cone_solver.solve_cone)
    conditioning = equilibrium.residuals.get("closure_conditioning", 1.0)
    library_statics_tolerance = max(1e-9, 1e-15 / max(conditioning, 1e-300))
    failed = (
        [k for k, tol in tolerances.items() if k != "torsor" and errors[k] > tol]
        + (["library_statics"] if errors["library_statics"] > library_statics_tolerance else [])
        + ([] if equilibrium.ok else ["ok"])
    )
    skewed = max(
        (
            float(np.abs(j.rotation.T @ j.rotation - np.eye(3)).max())
            for j in mechanism.joints.values()
        ),
        default=0.0,
    )
    if failed and skewed > 1e-12:  # known issue: a clearance frame that is not a rotation
        return Verdict("known-skewed-frame", errors, _summary(equilibrium, result))
    certified = certificate_holds(oracle, equilibrium, loads, result)
    if failed and certified and set(failed) <= {"energy"}:
        # the library's answer carries a KKT certificate in the oracle's own formulation, and
        # the energies differ by no more than the closure residuals allow (finding 9 of issue
        # 10: a load mostly carried by rigid directions, round-off closure rows)
        return Verdict(_certified_kind(flat), errors, _summary(equilibrium, result))
    if failed and roundoff:
        return Verdict("ambiguous-closure", errors, _summary(equilibrium, result))
    if failed and oracle.ambiguous_free:
        return Verdict("ambiguous-free-motion", errors, _summary(equilibrium, result))
    own_violation, own_equality = oracle.violations_of(result.twists)
    if failed and max(own_violation, own_equality) > 1e-9:
        return Verdict("oracle-inaccurate", errors, _summary(equilibrium, result))
    if failed and not equilibrium.polished and set(failed) <= {"statics", "library_statics"}:
        return Verdict("known-unpolished", errors, _summary(equilibrium, result))
    if failed:
        return Verdict("FAIL-" + "+".join(failed), errors, _summary(equilibrium, result))
    if flat:
        return Verdict("agree-flat", errors)
    if not result.polished:
        return Verdict("agree-energy", errors)  # the oracle's torsors have only IPM accuracy
    if errors["torsor"] > tolerances["torsor"] and certified and flat:
        # both optimal on a flat (non-unique) face that the library reports as such
        return Verdict("agree-flat", errors, _summary(equilibrium, result))
    if errors["torsor"] > tolerances["torsor"]:
        kind = (
            "known-unpolished"
            if not equilibrium.polished
            else "ambiguous-closure"
            if roundoff
            else "ambiguous-free-motion"
            if oracle.ambiguous_free
            else "known-skewed-frame"
            if skewed > 1e-12
            else "FAIL-torsor"
        )
        return Verdict(kind, errors, _summary(equilibrium, result))
    gaps = oracle.gaps_of(result.twists)
    active = {c.label for c in equilibrium.active_contacts}
    loaded = set(result.active)
    touching = {label for label, gap in gaps.items() if gap <= 1e-6}
    if not loaded <= active <= touching:
        return Verdict(
            "FAIL-contacts",
            errors,
            f"library {sorted(active)}; oracle loaded "
            f"{sorted(loaded)}, touching {sorted(touching)}",
        )
    return Verdict("agree", errors)


CERTIFICATE_TOLERANCE = 1e-9


def certificate_holds(oracle: Oracle, equilibrium, loads, result: OracleResult) -> bool:
    """Whether the library's answer is a certified optimum of the oracle's problem: KKT
    residuals of :meth:`Oracle.certificate_of` within 1e-9, and the oracle's own answer lower
    in energy by no more than (twice) what its closure residuals allow
    (:meth:`Oracle.energy_gap_bound`)."""
    residuals = oracle.certificate_of(equilibrium, loads)
    if max(residuals.values()) > CERTIFICATE_TOLERANCE:
        return False
    bound = oracle.energy_gap_bound(equilibrium, loads, result.twists)
    return equilibrium.energy <= result.energy + 2.0 * bound + 1e-12 * abs(result.energy)


def _certified_kind(flat: bool) -> str:
    """``agree-flat`` when the library reports the optimum as non-unique, else
    ``agree-certified``."""
    return "agree-flat" if flat else "agree-certified"


def _summary(equilibrium, result) -> str:
    return (
        f"library: polished={equilibrium.polished} solver={equilibrium.solver_status!r} "
        f"energy={equilibrium.energy!r} conditioning="
        f"{equilibrium.residuals.get('closure_conditioning')}; oracle: energy={result.energy!r} "
        f"polished={result.polished} active={result.active}"
    )

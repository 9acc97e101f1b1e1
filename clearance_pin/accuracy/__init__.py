r"""The accuracy map of a robot: how far its output settles from where the controller puts it, over
poses and payloads, split by joint and by source (issue 23, docs/method.md "The accuracy map").

For each pose :math:`q_i` (the driven joints' commands) and payload :math:`P_k`, the mechanism
settles inside its joint play (:meth:`~clearance_pin.mechanism.Mechanism.solve_many`, the
small-displacement model). The output frame's displacement is the sum, over the joints between
the ground and the output, of what each joint's torsor :math:`T_j = (v_j, \omega_j)` (clearance
frame, origin at the joint centre :math:`c_j`, axes :math:`R_j`) moves it:

.. math::  \delta p = \sum_j R_j v_j + (R_j \omega_j) \times (p - c_j), \qquad
           \delta\theta = \sum_j R_j \omega_j

(:math:`p`: the output's nominal origin at :math:`q_i`, world axes). Each joint's term is split by
source: its play on the component its drive turns (``"backlash"``: a driven joint's lost motion)
and on the others (``"play"``: the bearing's radial, axial and tilt play), and, for a joint with
stiffness, its elastic deflection (:meth:`~clearance_pin.equilibrium.result.Equilibrium.deflection`)
on the drive's component (``"drive compliance"``) and on the others (``"bearing compliance"``).

A motion no load holds (a driven joint without load torque anywhere in its backlash, a journal's
axial play under a radial load: a single solve's ``free_motions``) widens the answer into a band:
the map's ``reach`` is the output's largest distance from its nominal place over the settled
state and those motions (:mod:`.reach`). A tree of independent joint blocks is solved in one pass
over the poses, the payloads as columns (:mod:`.tree_map`).
"""

from .accuracy_map import AccuracyMap, accuracy_map

__all__ = ["AccuracyMap", "accuracy_map"]

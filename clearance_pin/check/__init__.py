r"""Cross-check of a solved pose with coal (docs/method.md section 5): ``Equilibrium.check()``.

Place the parts at the solved pose (``Equilibrium.body_placements``) and let coal measure every
clearance. For every contact point of every joint, the point of the child is measured against its
clearance region carried by the parent, a solid primitive (:mod:`.geometry`), which gives coal's
reading :math:`D` of the gap the model calls :math:`g` (``Contact.gap``). With the tolerance
:math:`\tau` of the reading (faceting + rim + solver + coal, each term stated, :mod:`.accuracy`):

.. math::  |D| \le \tau \ \text{(predicted contact)}, \qquad |D - g| \le \tau \ \text{(predicted
           free)}, \qquad D \ge -\tau \ \text{(no penetration)}.

Optionally the surfaces are measured too (:mod:`.surfaces`): a journal cylinder in a generated
faceted bore, and the URDF's collision parts. The small-displacement model gets no allowance: a
linear pose that sits off the real boundaries fails, and the report says by how much.

coal is imported, and its shapes built (once per mechanism), only when a check runs.

Modules: :mod:`.geometry` (coal shapes), :mod:`.poses` (clearance frames at the pose),
:mod:`.accuracy` (the tolerance terms), :mod:`.measure` (coal's calls), :mod:`.surfaces` (bores and
parts), :mod:`.report` (the answer), :mod:`.check` (the verb).
"""

from .accuracy import Tolerance
from .check import CHECK_OPTIONS, check_equilibrium
from .report import CheckReport, JointCheck, PointCheck

__all__ = [
    "CHECK_OPTIONS",
    "check_equilibrium",
    "CheckReport",
    "JointCheck",
    "PointCheck",
    "Tolerance",
]

"""Identification of a robot's drives (issue 35, docs/identification.md): each driven joint's
backlash and drive stiffness from measured deflections of one point, where to measure
(D-optimal design), and the accuracy the identified robot predicts at the ISO 9283 test poses.

- :mod:`.measurements`: the measurement file (CSV) and :class:`Measurements`;
- :mod:`.differences`: the model of the measured point's displacement, linear in the drives'
  backlash and compliance, from the project's own solver;
- :mod:`.fit`: the least squares and their statistics;
- :mod:`.identify`: :func:`identify` (``Mechanism.identify``) and its :class:`Identification`;
- :mod:`.clearance_output`: the identified values as a TOML clearance file;
- :mod:`.design`: where to measure (:func:`design_measurements`);
- :mod:`.iso9283`: the ISO 9283 test cube's poses and the accuracy predicted there;
- :mod:`.command`: ``clearance-pin identify``.
"""

from .identify import Identification, IdentifiedParameter, identify
from .measurements import Measurements, read_measurements

__all__ = ["Identification", "IdentifiedParameter", "Measurements", "identify", "read_measurements"]

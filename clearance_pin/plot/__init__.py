"""Pictures of equilibria (matplotlib, the ``plot`` extra) and an interactive view (meshcat, the
``viz`` extra). Neither is imported by ``import clearance_pin`` nor by this package: each is
imported when a picture is drawn or a view is served, and its absence is a
:class:`~clearance_pin.errors.ClearancePinError` that says what to install.

- :func:`plot_equilibrium`: the settled pose beside the nominal one, magnified, with the play to
  scale, the contacts and their forces (:mod:`.settled`, geometry in :mod:`.skeleton`);
- :func:`plot_trajectory`: along a trajectory of the driven joint (``solve_many(configurations=
  ...)``): the outputs' deviation, the contact forces and the contact-mode changes
  (:mod:`.trajectory`);
- :func:`show_equilibrium`: the URDF's visual meshes at the magnified settled pose in a browser,
  with a legend and a scale bar (:mod:`.viz`; meshcat, or viser with ``backend="viser"``:
  :mod:`.viz_viser`);
- :func:`show_trajectory`: a batch along a path played in the browser, one step per answer.
"""

from .settled import contact_arrows, plot_equilibrium
from .skeleton import Skeleton, magnify, skeleton
from .trajectory import contact_modes, plot_trajectory
from .viz import View, show_equilibrium, show_trajectory

__all__ = [
    "plot_equilibrium",
    "plot_trajectory",
    "show_equilibrium",
    "show_trajectory",
    "skeleton",
    "Skeleton",
    "magnify",
    "contact_arrows",
    "contact_modes",
    "View",
]

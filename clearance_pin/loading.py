"""Build a mechanism from a model file: :func:`load` (a path) and :func:`loads` (its text).

The model layer reads the file (:mod:`clearance_pin.model.model_file`: URDF + ``<clearance_pin>``
block, format in docs/model-format.md) into a description; the mechanism is built from it here, so
the model layer depends on nothing above it.
"""

from __future__ import annotations

from pathlib import Path

from .mechanism import Mechanism
from .model.model_file import PackageDirs, read_file, read_text


def load(path: str | Path, package_dirs: PackageDirs = None) -> Mechanism:
    """Read a mechanism from a model file (URDF + ``<clearance_pin>``).

    Args:
        path: the ``.urdf`` file, in the encoding its XML declaration names (UTF-8 without one).
        package_dirs: directories in which collision meshes are looked for: a ``package://pkg/f``
            mesh is ``<dir>/pkg/f``, a relative one ``<dir>/f``; then the file's own directory
            and the entries of the environment variable ROS_PACKAGE_PATH. Meshes are read only
            when a check needs them (``Equilibrium.check``), never to solve.

    Returns:
        :class:`~clearance_pin.mechanism.Mechanism`, loops closed.

    Raises:
        ModelError: the file is unreadable or invalid (naming the file, the element and the
            problem), or its loops cannot be closed.
    """
    return Mechanism(**read_file(path, package_dirs).arguments())


def loads(
    text: str | bytes,
    source: str = "<string>",
    mesh_dir: Path | None = None,
    package_dirs: PackageDirs = None,
) -> Mechanism:
    """Read a mechanism from the text of a model file (see :func:`load`).

    Args:
        text: the file's text (str), or its bytes, decoded as its XML declaration says.
        source: the name used in messages.
        mesh_dir: directory of relative mesh paths (the file's directory).
        package_dirs: as in :func:`load`.
    """
    return Mechanism(**read_text(text, source, mesh_dir, package_dirs).arguments())


__all__ = ["load", "loads"]

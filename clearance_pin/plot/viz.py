"""An interactive view in a browser: the URDF's visual meshes at the magnified settled pose
(meshcat, the ``viz`` extra: ``pip install clearance_pin[viz]``; imported only when a view is
served).

:func:`show_equilibrium` starts a meshcat server on this machine (127.0.0.1: a WebSocket and
static page server, in a process of its own), loads the URDF's ``<visual>`` geometry (meshes and
primitives, through Pinocchio's meshcat loader) and places every part at its settled pose with the
displacement magnified m times, as :func:`~clearance_pin.plot.settled.plot_equilibrium` draws it:
a point of a part nominally at :math:`p_0` is shown at :math:`p_0 + m (R p_0 + t - p_0)` for the
part's settled motion :math:`(R, t)` (an affine placement, exact for the relative motion inside
each joint). Beside the meshes the skeleton is drawn (nominal in grey, settled in blue, the play
in orange, contact forces in red, applied forces in green). A URDF without visual geometry (the
bundled models) is shown as its skeleton alone.

Open :attr:`View.url` in a browser; :meth:`View.close` stops the server (also at exit).
"""

from __future__ import annotations

import contextlib
import importlib
import io
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import pinocchio as pin

from ..equilibrium.result import Equilibrium
from ..errors import ArgumentError, ClearancePinError, ClearancePinWarning
from ..model.description import model_source
from .skeleton import FloatArray, Skeleton, magnify, play_outlines, skeleton

if TYPE_CHECKING:
    from ..mechanism import Mechanism

FORCE_FRACTION = 0.15  # the largest force drawn at about 15 % of the size, as in the pictures
COLOURS = {"nominal": 0x999999, "settled": 0x1F77B4, "play": 0xFF7F0E, "contact": 0xD62728,
           "load": 0x2CA02C}  # fmt: skip


@dataclass
class View:
    """A served interactive view.

    Attributes:
        url: the page to open in a browser (``http://127.0.0.1:<port>/static/``).
        magnification: the factor m on every displacement and play.
        meshes: the URDF's visual geometry is shown (False: the skeleton alone).
        paths: the scene paths that were sent (objects and transforms).
        viewer: the ``meshcat.Visualizer``.
    """

    url: str
    magnification: float
    meshes: bool
    paths: tuple[str, ...]
    viewer: Any = field(repr=False)

    def scene_html(self) -> str:
        """The scene as one standalone HTML page (meshcat's static export)."""
        return str(self.viewer.static_html())

    def close(self) -> None:
        """Stop the meshcat server this view started (nothing when it joined another one)."""
        process = getattr(self.viewer.window, "server_proc", None)
        if process is not None and process.poll() is None:
            process.kill()
            process.wait()

    def __enter__(self) -> View:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()


def show_equilibrium(
    equilibrium: Equilibrium,
    magnification: float | None = None,
    *,
    visual_model: Any = None,
    package_dirs: Sequence[str | Path] = (),
    zmq_url: str | None = None,
    open_browser: bool = False,
    show_skeleton: bool = True,
) -> View:
    """Serve ``equilibrium``'s settled pose, magnified, to a browser; returns the :class:`View`.

    Args:
        equilibrium: a solved :class:`~clearance_pin.equilibrium.result.Equilibrium`.
        magnification: factor m on every displacement (default: as the pictures, the largest
            displacement at about 5 % of the mechanism's size).
        visual_model: a ``pin.GeometryModel`` of the mechanism's model to show (default: the
            ``<visual>`` elements of the URDF the mechanism was loaded from).
        package_dirs: directories searched for ``package://`` and relative meshes, before the
            URDF's own directory (ROS_PACKAGE_PATH is searched by Pinocchio).
        zmq_url: join a running ``meshcat-server`` (default: start one on 127.0.0.1).
        open_browser: open the page in the default browser.
        show_skeleton: draw the skeleton, play, contacts and forces beside the meshes (always
            drawn when there is no visual geometry).

    Raises:
        ClearancePinError: meshcat is missing (``pip install clearance_pin[viz]``).
        ArgumentError: a magnification that is not a positive number.
    """
    try:
        meshcat = importlib.import_module("meshcat")  # untyped: read as Any
    except ImportError:
        raise ClearancePinError(
            "the interactive view needs meshcat: pip install clearance_pin[viz]"
        ) from None
    bones = skeleton(equilibrium)
    m = bones.default_magnification() if magnification is None else float(magnification)
    if not np.isfinite(m) or m <= 0.0:
        raise ArgumentError("magnification", "a positive number", magnification)
    mechanism = cast("Mechanism", equilibrium.mechanism)
    geometry = visual_model if visual_model is not None else _visuals(mechanism, package_dirs)
    with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints its address: View.url
        viewer = meshcat.Visualizer(zmq_url=zmq_url)
    root = _name(str(mechanism.name)) or "mechanism"
    sent: list[str] = []
    meshes = geometry is not None and len(geometry.geometryObjects) > 0
    try:
        if meshes:
            sent += _place_meshes(viewer, equilibrium, mechanism, geometry, m, root)
        if show_skeleton or not meshes:
            sent += _draw_skeleton(viewer, bones, m, f"{root}/skeleton")
        _aim_camera(viewer, bones)
    except BaseException:
        View("", m, meshes, (), viewer).close()
        raise
    view = View(str(viewer.url()), m, meshes, tuple(sent), viewer)
    if open_browser:
        viewer.open()
    return view


def _visuals(mechanism: Mechanism, package_dirs: Sequence[str | Path]) -> Any:
    """The model file's visual geometry (a URDF's ``<visual>`` elements, an MJCF file's geoms),
    or None (no model file, no visual element, a mesh missing: warned, and the skeleton is shown
    instead). The model file is the mechanism's source without its clearance file beside it."""
    source = Path(model_source(str(mechanism.source)))
    if not source.is_file():
        return None
    dirs = [str(d) for d in package_dirs] + [str(source.parent)]
    try:
        if source.suffix.lower() == ".xml":  # MJCF
            return pin.buildGeomFromMJCF(mechanism.model, str(source), pin.GeometryType.VISUAL)
        return pin.buildGeomFromUrdf(
            mechanism.model, str(source), pin.GeometryType.VISUAL, package_dirs=dirs
        )
    except (RuntimeError, ValueError) as exc:
        warnings.warn(
            f"{source}: the visual geometry cannot be loaded ({exc}); showing the skeleton",
            ClearancePinWarning,
            stacklevel=3,
        )
        return None


def magnified_motion(nominal: Any, settled: Any, magnification: float) -> FloatArray:
    """The affine map (4, 4) taking a part's nominal world points to where the view shows them:
    :math:`p_0 \\mapsto p_0 + m (R p_0 + t - p_0)` for its motion :math:`(R, t)` = settled x
    nominal^-1 (placements ``pin.SE3`` of the part at both poses)."""
    motion = settled * nominal.inverse()
    affine = np.eye(4)
    affine[:3, :3] = np.eye(3) + magnification * (np.asarray(motion.rotation) - np.eye(3))
    affine[:3, 3] = magnification * np.asarray(motion.translation)
    return affine


def _place_meshes(
    viewer: Any, equilibrium: Equilibrium, mechanism: Mechanism, geometry: Any, m: float, root: str
) -> list[str]:
    """Load every visual object through Pinocchio's meshcat loader and place it, magnified."""
    from pinocchio.visualize import MeshcatVisualizer

    loader = MeshcatVisualizer(mechanism.model, None, geometry)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        loader.initViewer(viewer=viewer)
        loader.loadViewerModel(rootNodeName=root)
    nominal = cast(Any, equilibrium.configuration).oMi
    placed = equilibrium.body_placements
    sent = []
    for obj in geometry.geometryObjects:
        body = obj.parentJoint
        start = (nominal[body] * obj.placement).homogeneous
        scale = np.diag([*np.asarray(obj.meshScale, dtype=float), 1.0])
        matrix = magnified_motion(nominal[body], placed[body], m) @ start @ scale
        node = loader.getViewerNodeName(obj, pin.GeometryType.VISUAL)
        viewer[node].set_transform(matrix)
        sent.append(node)
    return sent


def _draw_skeleton(viewer: Any, bones: Skeleton, m: float, root: str) -> list[str]:
    """The skeleton as line sets and spheres under ``root``."""
    mg = importlib.import_module("meshcat.geometry")

    def lines(path: str, pairs: list[tuple[FloatArray, FloatArray]], colour: int) -> None:
        if not pairs:
            return
        points = np.array([p for pair in pairs for p in pair], dtype=np.float32).T
        viewer[path].set_object(
            mg.LineSegments(mg.PointsGeometry(points), mg.LineBasicMaterial(color=colour))
        )
        sent.append(path)

    sent: list[str] = []
    drawn = magnify(bones.points, bones.moved, m)
    links = [(a, b) for a, b in bones.links]
    lines(f"{root}/nominal", [(bones.points[a], bones.points[b]) for a, b in links],
          COLOURS["nominal"])  # fmt: skip
    size = bones.size()
    material = mg.MeshLambertMaterial(color=COLOURS["settled"])
    for k, (a, b) in enumerate(links):
        placement = _along(drawn[a], drawn[b])
        if placement is None:
            continue
        path = f"{root}/settled/{k}"
        length = float(np.linalg.norm(drawn[b] - drawn[a]))
        viewer[path].set_object(mg.Cylinder(length, 0.004 * size), material)
        viewer[path].set_transform(placement)
        sent.append(path)
    sphere = mg.Sphere(0.008 * size)
    for joint in bones.joints:
        path = f"{root}/joints/{_name(joint.name)}"
        viewer[path].set_object(sphere, mg.MeshLambertMaterial(color=COLOURS["settled"]))
        at = np.eye(4)
        at[:3, 3] = magnify(joint.journal, joint.journal_moved, m)
        viewer[path].set_transform(at)
        sent.append(path)
        rings = [
            (ring[i], ring[i + 1]) for ring in play_outlines(joint, m) for i in range(len(ring) - 1)
        ]
        lines(f"{root}/play/{_name(joint.name)}", rings, COLOURS["play"])
    largest = max(
        [float(np.linalg.norm(c.force)) for c in bones.active_contacts]
        + [float(np.linalg.norm(f.force)) for f in bones.loads]
        + [0.0]
    )
    per_newton = FORCE_FRACTION * size / largest if largest > 0.0 else 0.0  # [m/N]
    for contact in bones.active_contacts:
        at = magnify(contact.point, contact.moved, m)
        lines(f"{root}/contacts/{_name(contact.label)}", [(at - contact.force * per_newton, at)],
              COLOURS["contact"])  # fmt: skip
    for load in bones.loads:
        at = magnify(load.point, load.moved, m)
        lines(f"{root}/loads/{_name(load.label)}", [(at, at + load.force * per_newton)],
              COLOURS["load"])  # fmt: skip
    return sent


def _along(start: FloatArray, end: FloatArray) -> FloatArray | None:
    """The placement (4, 4) of a meshcat cylinder (axis y, centred) from ``start`` to ``end``."""
    axis = end - start
    length = float(np.linalg.norm(axis))
    if length <= 0.0:
        return None
    y = axis / length
    seed = np.eye(3)[int(np.argmin(np.abs(y)))]
    x = np.cross(y, seed)
    x /= np.linalg.norm(x)
    placement = np.eye(4)
    placement[:3, :3] = np.column_stack([x, y, np.cross(x, y)])
    placement[:3, 3] = 0.5 * (start + end)
    return placement


def _aim_camera(viewer: Any, bones: Skeleton) -> None:
    """Hide meshcat's 1 m axes and grid, and look at the mechanism from about twice its size
    (the camera orbits the world origin; three.js axes, y up)."""
    viewer["/Axes"].set_property("visible", False)
    viewer["/Grid"].set_property("visible", False)
    middle = bones.points.mean(axis=0) if len(bones.points) else np.zeros(3)
    d = 1.3 * bones.size() + float(np.linalg.norm(middle))
    viewer["/Cameras/default/rotated/<object>"].set_property("position", [d, 0.6 * d, d])


def _name(text: str) -> str:
    """A scene path entry: letters, digits, ``_``, ``-`` and ``.`` kept, the rest ``_``."""
    return re.sub(r"[^A-Za-z0-9_.\-]+", "_", text).strip("_")

r"""An interactive view in a browser: the URDF's visual meshes at the magnified settled pose
(meshcat, the ``viz`` extra: ``pip install clearance_pin[viz]``; or viser, the ``viser`` extra;
imported only when a view is served).

:func:`show_equilibrium` starts a meshcat server on this machine (127.0.0.1: a WebSocket and
static page server, in a process of its own), loads the URDF's ``<visual>`` geometry (meshes and
primitives, through Pinocchio's meshcat loader) and places every part at its settled pose with the
displacement magnified m times, as :func:`~clearance_pin.plot.settled.plot_equilibrium` draws it:
a point of a part nominally at :math:`p_0` is shown at :math:`p_0 + m (R p_0 + t - p_0)` for the
part's settled motion :math:`(R, t)` (an affine map, :func:`magnified_motion`; it is not rigid:
:math:`I + m (R - I)` stretches the part across its rotation axis by a factor about
:math:`1 + (m \theta)^2 / 2`). three.js keeps only translation, rotation and per-axis scale of
a node, so each part's map is sent as two nodes (:func:`split_affine`): its node gets
:math:`U \Sigma` and the object under it :math:`V^T`, from :math:`U \Sigma V^T`, and the browser
draws the affine map exactly. Beside the meshes the skeleton is drawn (nominal in grey, settled in
blue, the play in orange, contact forces in red, applied forces in green). A URDF without visual
geometry (the bundled models) is shown as its skeleton alone.

The view states its scales in the scene, below the model, facing the first camera: a legend
(``displacements and play x200``, the largest play and its drawn size) and a scale bar: a black
bar whose drawn length is a round displacement times m (``bar: 100 um of displacement``). The parts
themselves are at true size (metres).

:func:`show_trajectory` plays the answers of a batch along a path (``solve_many(configurations=
...)``) as a meshcat animation, one step per answer, with one magnification for every step.

``backend="viser"`` serves the same magnified pose with viser (:mod:`.viz_viser`).

Open :attr:`View.url` in a browser; :meth:`View.close` stops the server (also at exit).
"""

from __future__ import annotations

import contextlib
import importlib
import io
import re
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import pinocchio as pin

from ..equilibrium.result import Equilibrium
from ..errors import ArgumentError, ClearancePinError, ClearancePinWarning
from ..model.description import model_source
from .skeleton import (
    DISPLACEMENT_FRACTION,
    FloatArray,
    Skeleton,
    force_arrows,
    magnify,
    play_segments,
    skeleton,
)
from .style import nice_round, number

if TYPE_CHECKING:
    from ..mechanism import Mechanism

FORCE_FRACTION = 0.15  # the largest force drawn at about 15 % of the size, as in the pictures
BAR_FRACTION = 0.2  # the scale bar drawn at about 20 % of the size
COLOURS = {"nominal": 0x999999, "settled": 0x1F77B4, "play": 0xFF7F0E, "contact": 0xD62728,
           "load": 0x2CA02C, "legend": 0x000000}  # fmt: skip
CAMERA = np.array([1.0, -1.0, 0.6]) / np.linalg.norm([1.0, -1.0, 0.6])  # world, from the centre
DISCRETE = 2300  # THREE.InterpolateDiscrete: a playback steps from answer to answer
BACKENDS = ("meshcat", "viser")


@dataclass
class View:
    """A served interactive view.

    Attributes:
        url: the page to open in a browser (meshcat: ``http://127.0.0.1:<port>/static/``).
        magnification: the factor m on every displacement and play.
        meshes: the URDF's visual geometry is shown (False: the skeleton alone).
        paths: the scene paths that were sent (objects and transforms).
        viewer: the ``meshcat.Visualizer`` (``viser.ViserServer`` for the viser backend).
        legend: the legend's lines, as shown in the scene (magnification, scale bar, play).
        bar: the displacement the scale bar stands for [m] (drawn ``magnification`` times
            longer).
        frames: the answers played (1 for one equilibrium).
        backend: ``"meshcat"`` or ``"viser"``.
        handles: viser's scene handles by scene path (empty for meshcat).
    """

    url: str
    magnification: float
    meshes: bool
    paths: tuple[str, ...]
    viewer: Any = field(repr=False)
    legend: tuple[str, ...] = ()
    bar: float = 0.0
    frames: int = 1
    backend: str = "meshcat"
    handles: dict[str, Any] = field(default_factory=dict, repr=False)
    stop: Callable[[], None] | None = field(default=None, repr=False)

    def scene_html(self) -> str:
        """The scene as one standalone HTML page (meshcat's static export; meshcat only)."""
        if self.backend != "meshcat":
            raise ClearancePinError(f"scene_html: the {self.backend} view has no static export")
        return str(self.viewer.static_html())

    def close(self) -> None:
        """Stop the server this view started (nothing when it joined another one)."""
        if self.stop is not None:
            self.stop()
            return
        process = getattr(getattr(self.viewer, "window", None), "server_proc", None)
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
    backend: str = "meshcat",
    visual_model: Any = None,
    package_dirs: Sequence[str | Path] = (),
    zmq_url: str | None = None,
    port: int | None = None,
    open_browser: bool = False,
    show_skeleton: bool = True,
) -> View:
    """Serve ``equilibrium``'s settled pose, magnified, to a browser; returns the :class:`View`.

    Args:
        equilibrium: a solved :class:`~clearance_pin.equilibrium.result.Equilibrium`.
        magnification: factor m on every displacement (default: as the pictures, the largest
            displacement at about 5 % of the mechanism's size).
        backend: ``"meshcat"`` (the ``viz`` extra) or ``"viser"`` (the ``viser`` extra:
            :mod:`.viz_viser`, the same pose, each part's vertices moved by the affine map).
        visual_model: a ``pin.GeometryModel`` of the mechanism's model to show (default: the
            ``<visual>`` elements of the URDF the mechanism was loaded from).
        package_dirs: directories searched for ``package://`` and relative meshes, before the
            URDF's own directory (ROS_PACKAGE_PATH is searched by Pinocchio).
        zmq_url: meshcat: join a running ``meshcat-server`` (default: start one on 127.0.0.1).
        port: viser: the port to serve on (default: viser's, 8080, or the next free one).
        open_browser: open the page in the default browser.
        show_skeleton: draw the skeleton, play, contacts and forces beside the meshes (always
            drawn when there is no visual geometry).

    Raises:
        ClearancePinError: meshcat (or viser) is missing (``pip install clearance_pin[viz]``).
        ArgumentError: a magnification that is not a positive number, an unknown backend.
    """
    if backend not in BACKENDS:
        raise ArgumentError("backend", " or ".join(repr(b) for b in BACKENDS), backend)
    bones = skeleton(equilibrium)
    m = _magnification(magnification, [bones])
    mechanism = cast("Mechanism", equilibrium.mechanism)
    if backend == "viser":
        from .viz_viser import show_viser

        geometry = visual_model if visual_model is not None else _visuals(mechanism, package_dirs)
        return show_viser(equilibrium, bones, m, geometry, port, open_browser, show_skeleton)
    meshcat = _meshcat()
    geometry = visual_model if visual_model is not None else _visuals(mechanism, package_dirs)
    with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints its address: View.url
        viewer = meshcat.Visualizer(zmq_url=zmq_url)
    root = _name(str(mechanism.name)) or "mechanism"
    sent: list[str] = []
    meshes = geometry is not None and len(geometry.geometryObjects) > 0
    legend: tuple[str, ...] = ()
    bar = 0.0
    try:
        if meshes:
            intrinsic = _load_meshes(viewer, mechanism, geometry, root)
            for node, obj in intrinsic.items():
                matrix = part_matrix(equilibrium, obj.geometry_object, m)
                _send_part(viewer, node, matrix, obj.matrix)
                sent.append(node)
        if show_skeleton or not meshes:
            sent += _draw_skeleton(viewer, bones, m, f"{root}/skeleton")
        legend, bar = scale_legend(m, bones.size(), _largest_play([bones]), meshes)
        sent += _draw_legend(viewer, legend, m * bar, bones, f"{root}/legend")
        _aim_camera(viewer, bones, root)
    except BaseException:
        View("", m, meshes, (), viewer).close()
        raise
    view = View(str(viewer.url()), m, meshes, tuple(sent), viewer, legend, bar)
    if open_browser:
        viewer.open()
    return view


def show_trajectory(
    batch: Sequence[Equilibrium | Exception],
    magnification: float | None = None,
    *,
    fps: float = 4.0,
    visual_model: Any = None,
    package_dirs: Sequence[str | Path] = (),
    zmq_url: str | None = None,
    open_browser: bool = False,
    show_skeleton: bool = True,
    play: bool = True,
) -> View:
    """Play the settled poses of ``batch`` (meshcat): one animation step per answer, every
    step with the same magnification; returns the :class:`View` (:attr:`View.frames` steps).

    The parts (the URDF's visual geometry) move from step to step by the affine map of
    :func:`magnified_motion` of each answer (exactly, see :func:`split_affine`); the skeleton,
    the play and the forces of each answer are drawn once and shown at its step only. Steps do
    not blend: between two answers nothing is interpolated (an average of two equilibria is
    none). meshcat's controls, *Animations*, play, pause and scrub the steps; the legend names
    the magnification and the scale bar.

    Args:
        batch: the answer of ``mechanism.solve_many(configurations=...)`` (or any sequence of
            equilibria of one mechanism; failed cases, errors returned with
            ``errors="return"``, are left out and counted in the legend).
        magnification: factor m on every displacement of every step (default: the largest
            displacement along the whole batch at about 5 % of the mechanism's size).
        fps: steps per second [1/s] of the playback.
        visual_model, package_dirs, zmq_url, open_browser, show_skeleton: as
            :func:`show_equilibrium`.
        play: start playing when the page opens (meshcat plays once and stays on the last
            step).

    Raises:
        ClearancePinError: meshcat is missing; the batch holds no equilibrium.
        ArgumentError: a magnification or fps that is not a positive number; answers of
            different mechanisms.
    """
    items = list(batch)
    answers = [item for item in items if isinstance(item, Equilibrium)]
    if not answers:
        raise ClearancePinError("show_trajectory: the batch has no equilibrium (every case failed)")
    if not np.isfinite(fps) or fps <= 0.0:
        raise ArgumentError("fps", "a positive number of steps per second", fps)
    mechanism = cast("Mechanism", answers[0].mechanism)
    if any(a.mechanism is not mechanism for a in answers):
        raise ArgumentError("batch", "equilibria of one mechanism", "answers of several")
    bones = [skeleton(a) for a in answers]
    m = _magnification(magnification, bones)
    meshcat = _meshcat()
    geometry = visual_model if visual_model is not None else _visuals(mechanism, package_dirs)
    with contextlib.redirect_stdout(io.StringIO()):
        viewer = meshcat.Visualizer(zmq_url=zmq_url)
    root = _name(str(mechanism.name)) or "mechanism"
    sent: list[str] = []
    meshes = geometry is not None and len(geometry.geometryObjects) > 0
    tracks = _Tracks()
    size = max(b.size() for b in bones)
    try:
        if meshes:
            intrinsic = _load_meshes(viewer, mechanism, geometry, root)
            for node, obj in intrinsic.items():
                for k, answer in enumerate(answers):
                    matrix = part_matrix(answer, obj.geometry_object, m)
                    group, turn = split_affine(matrix)
                    if k == 0:
                        _send_part(viewer, node, matrix, obj.matrix)
                    tracks.node(viewer[node].path.lower(), k, group)
                    tracks.node(viewer[node]["<object>"].path.lower(), k, turn @ obj.matrix)
                sent.append(node)
        if show_skeleton or not meshes:
            for k, bone in enumerate(bones):
                path = f"{root}/skeleton/{k}"
                sent += _draw_skeleton(viewer, bone, m, path, size)
                viewer[path].set_property("visible", k == 0)
                visible = viewer[path].path.lower()
                if k > 0:
                    tracks.key(visible, "visible", "boolean", 0.0, False)
                tracks.key(visible, "visible", "boolean", float(k), True)
                if k + 1 < len(bones):
                    tracks.key(visible, "visible", "boolean", float(k + 1), False)
        legend, bar = scale_legend(m, size, _largest_play(bones), meshes)
        failed = len(items) - len(answers)
        legend += (f"{len(answers)} answers, {number(fps)} per second",)
        if failed:
            legend += (f"{failed} failed cases left out",)
        sent += _draw_legend(viewer, legend, m * bar, bones[0], f"{root}/legend")
        _aim_camera(viewer, bones[0], root)
        viewer.window.send(_Lowered(tracks.command(fps, play)))
    except BaseException:
        View("", m, meshes, (), viewer).close()
        raise
    view = View(str(viewer.url()), m, meshes, tuple(sent), viewer, legend, bar, len(answers))
    if open_browser:
        viewer.open()
    return view


def _meshcat() -> Any:
    try:
        return importlib.import_module("meshcat")  # untyped: read as Any
    except ImportError:
        raise ClearancePinError(
            "the interactive view needs meshcat: pip install clearance_pin[viz]"
        ) from None


def _magnification(magnification: float | None, bones: Sequence[Skeleton]) -> float:
    """The given magnification, checked, or the pictures' default over every skeleton: a round
    number drawing the largest displacement at about 5 % of the largest size."""
    if magnification is None:
        largest = max(b.largest_displacement() for b in bones)
        size = max(b.size() for b in bones)
        return nice_round(DISPLACEMENT_FRACTION * size / largest) if largest > 0.0 else 1.0
    m = float(magnification)
    if not np.isfinite(m) or m <= 0.0:
        raise ArgumentError("magnification", "a positive number", magnification)
    return m


def _largest_play(bones: Sequence[Skeleton]) -> float:
    """The largest radial play of any joint [m]."""
    return max((j.radial for b in bones for j in b.joints), default=0.0)


def length_text(value: float) -> str:
    """A length [m] as text in um, mm or m: ``50 um``, ``12.5 mm``, ``1.2 m``."""
    if value < 1e-3:
        return f"{value * 1e6:.3g} um"
    if value < 1.0:
        return f"{value * 1e3:.3g} mm"
    return f"{value:.3g} m"


def scale_legend(
    magnification: float, size: float, play: float, parts: bool = True
) -> tuple[tuple[str, ...], float]:
    """The legend's lines and the displacement the scale bar stands for [m].

    The bar stands for a round displacement (1-2-5 series) that, magnified, is drawn at about
    :data:`BAR_FRACTION` of ``size`` [m]; ``play`` [m] is the largest radial play (no line when
    0). E.g. at m = 200 on a 0.5 m mechanism with 50 um play: ``displacements and play x200``,
    ``bar: 500 um of displacement``, ``(drawn 100 mm)``, ``play 50 um drawn 10 mm``,
    ``parts at true size``, ``gaps: play and deflection`` (magnified as the rest); ``parts``
    False (no visual geometry, the skeleton alone): ``skeleton only: no meshes``."""
    m = magnification
    bar = nice_round(BAR_FRACTION * size / m)
    lines = [
        f"displacements and play x{number(m)}",
        f"bar: {length_text(bar)} of displacement",
        f"(drawn {length_text(m * bar)})",
    ]
    if play > 0.0:
        lines.append(f"play {length_text(play)} drawn {length_text(m * play)}")
    if parts:
        lines += ["parts at true size", "gaps: play and deflection"]
    else:
        lines.append("skeleton only: no meshes")
    return tuple(lines), bar


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


def part_matrix(equilibrium: Equilibrium, geometry_object: Any, magnification: float) -> FloatArray:
    """Where a visual object is shown (4, 4): its points in its own frame (mesh units, before
    ``meshScale``) to world [m], :func:`magnified_motion` of its part at ``equilibrium`` after
    its nominal placement and its mesh scale."""
    body = geometry_object.parentJoint
    nominal = cast(Any, equilibrium.configuration).oMi[body]
    placed = equilibrium.body_placements[body]
    start = np.asarray((nominal * geometry_object.placement).homogeneous)
    scale = np.diag([*np.asarray(geometry_object.meshScale, dtype=float), 1.0])
    matrix: FloatArray = magnified_motion(nominal, placed, magnification) @ start @ scale
    return matrix


def split_affine(matrix: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``matrix`` (4, 4, affine) as ``group @ turn``: ``group`` with orthogonal columns
    (:math:`U \\Sigma` and the translation: a rotation and a per-axis scale, which three.js keeps
    exactly) and ``turn`` a rotation (:math:`V^T`), from the singular value decomposition
    :math:`U \\Sigma V^T` of the linear part (U and V proper rotations, a reflection's sign kept
    in :math:`\\Sigma`)."""
    u, sigma, vt = np.linalg.svd(np.asarray(matrix, dtype=float)[:3, :3])
    if np.linalg.det(u) < 0.0:
        u[:, 2] *= -1.0
        sigma[2] *= -1.0
    if np.linalg.det(vt) < 0.0:
        vt[2, :] *= -1.0
        sigma[2] *= -1.0
    group = np.eye(4)
    group[:3, :3] = u * sigma
    group[:3, 3] = np.asarray(matrix, dtype=float)[:3, 3]
    turn = np.eye(4)
    turn[:3, :3] = vt
    return group, turn


def compose_trs(
    position: Sequence[float], quaternion: Sequence[float], scale: Sequence[float]
) -> FloatArray:
    """The matrix (4, 4) three.js makes of a node's position, quaternion (x, y, z, w) and scale:
    T R S."""
    x, y, z, w = (float(v) for v in quaternion)
    matrix = np.eye(4)
    matrix[:3, :3] = pin.Quaternion(w, x, y, z).toRotationMatrix() @ np.diag(scale)
    matrix[:3, 3] = position
    return matrix


def decompose_trs(matrix: FloatArray) -> tuple[list[float], list[float], list[float]]:
    """Position, quaternion (x, y, z, w) and scale of a matrix with orthogonal columns, as
    three.js's ``Matrix4.decompose`` reads it (a negative determinant: the x scale negated)."""
    linear = np.asarray(matrix, dtype=float)[:3, :3]
    scale = np.linalg.norm(linear, axis=0)
    if np.linalg.det(linear) < 0.0:
        scale[0] = -scale[0]
    rotation = linear / scale
    quaternion = pin.Quaternion(rotation).coeffs()  # x, y, z, w
    return (
        [float(v) for v in np.asarray(matrix)[:3, 3]],
        [float(v) for v in quaternion],
        [float(v) for v in scale],
    )


@dataclass(frozen=True)
class _Loaded:
    """A visual object loaded into meshcat and the matrix of its ``<object>`` as the browser
    reads it (the loader's intrinsic transform: a cylinder turned to three.js's y axis)."""

    geometry_object: Any
    matrix: FloatArray


class _Lowered:
    """A meshcat command already lowered to its message."""

    def __init__(self, data: dict[str, Any]) -> None:
        self.data = data

    def lower(self) -> dict[str, Any]:
        return self.data


def _load_meshes(viewer: Any, mechanism: Mechanism, geometry: Any, root: str) -> dict[str, _Loaded]:
    """Load every visual object through Pinocchio's meshcat loader; by scene path, the object
    and the matrix its ``<object>`` node got (read from the message sent)."""
    from pinocchio.visualize import MeshcatVisualizer

    loader = MeshcatVisualizer(mechanism.model, None, geometry)
    sent: dict[str, FloatArray] = {}
    window = viewer.window
    send = window.send

    def recording(command: Any) -> None:
        data = command.lower()
        if data["type"] == "set_object":
            matrix = data["object"].get("object", {}).get("matrix")
            sent[data["path"]] = (
                np.eye(4) if matrix is None else np.asarray(matrix, float).reshape(4, 4).T
            )  # column-major, as three.js reads it
        send(_Lowered(data))

    window.send = recording
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            loader.initViewer(viewer=viewer)
            loader.loadViewerModel(rootNodeName=root)
    finally:
        window.send = send
    loaded = {}
    for obj in geometry.geometryObjects:
        node = loader.getViewerNodeName(obj, pin.GeometryType.VISUAL)
        loaded[node] = _Loaded(obj, sent.get(viewer[node].path.lower(), np.eye(4)))
    return loaded


def _send_part(viewer: Any, node: str, matrix: FloatArray, intrinsic: FloatArray) -> None:
    """Show the object at ``node`` through the affine ``matrix``: its node gets the split's
    group, its ``<object>`` the split's turn before its intrinsic transform."""
    group, turn = split_affine(matrix)
    viewer[node].set_transform(group)
    viewer[node]["<object>"].set_transform(turn @ intrinsic)


class _Tracks:
    """Animation tracks by scene path and property, keyed by step (played ``fps`` per second),
    lowered as meshcat's ``set_animation`` with discrete steps."""

    def __init__(self) -> None:
        self.tracks: dict[str, dict[str, tuple[str, list[tuple[float, Any]]]]] = {}

    def key(self, path: str, prop: str, kind: str, step: float, value: Any) -> None:
        entry = self.tracks.setdefault(path, {}).setdefault(prop, (kind, []))
        entry[1].append((step, value))

    def node(self, path: str, step: int, matrix: FloatArray) -> None:
        position, quaternion, scale = decompose_trs(matrix)
        self.key(path, "position", "vector3", float(step), position)
        self.key(path, "quaternion", "quaternion", float(step), quaternion)
        self.key(path, "scale", "vector3", float(step), scale)

    def command(self, fps: float, play: bool) -> dict[str, Any]:
        animations = [
            {
                "path": path,
                "clip": {
                    "fps": float(fps),
                    "name": "default",
                    "tracks": [
                        {
                            "name": f".{prop}",
                            "type": kind,
                            "interpolation": DISCRETE,
                            "keys": [{"time": t, "value": v} for t, v in sorted(keys)],
                        }
                        for prop, (kind, keys) in props.items()
                    ],
                },
            }
            for path, props in self.tracks.items()
        ]
        return {
            "type": "set_animation",
            "animations": animations,
            "options": {"play": bool(play), "repetitions": 1},
            "path": "",
        }


def _draw_skeleton(
    viewer: Any, bones: Skeleton, m: float, root: str, size: float | None = None
) -> list[str]:
    """The skeleton as line sets and spheres under ``root`` (``size`` [m]: of the marks,
    default the skeleton's)."""
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
    size = bones.size() if size is None else size
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
        lines(f"{root}/play/{_name(joint.name)}", play_segments(joint, m), COLOURS["play"])
    for group, label, segment in force_arrows(bones, m, FORCE_FRACTION):
        colour = COLOURS["contact" if group == "contacts" else "load"]
        lines(f"{root}/{group}/{_name(label)}", [segment], colour)
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


def _screen_axes() -> tuple[FloatArray, FloatArray]:
    """The first camera's right and up directions, world (the camera looks along -CAMERA, z
    up)."""
    forward = -CAMERA
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    return right, np.cross(right, forward)


def centre(bones: Skeleton) -> FloatArray:
    """The centre of the box around the skeleton's nominal points [m] (the origin without)."""
    if not len(bones.points):
        return np.zeros(3)
    return np.asarray(0.5 * (bones.points.min(axis=0) + bones.points.max(axis=0)), dtype=float)


def legend_anchor(bones: Skeleton) -> FloatArray:
    """Where the scale bar starts [m]: below and left of the mechanism as the first camera
    sees it."""
    right, up = _screen_axes()
    size = bones.size()
    return np.asarray(centre(bones) - 0.5 * size * up - 0.3 * size * right, dtype=float)


def _draw_legend(
    viewer: Any, lines: tuple[str, ...], bar_drawn: float, bones: Skeleton, root: str
) -> list[str]:
    """The scale bar (``bar_drawn`` [m] long, black, along the first camera's right) and the
    legend's lines below it, each a text texture on a square plane facing that camera."""
    mg = importlib.import_module("meshcat.geometry")
    right, up = _screen_axes()
    size = bones.size()
    anchor = legend_anchor(bones)
    sent = []
    bar = _along(anchor, anchor + bar_drawn * right)
    if bar is not None:
        viewer[f"{root}/bar"].set_object(
            mg.Cylinder(bar_drawn, 0.006 * size), mg.MeshLambertMaterial(color=COLOURS["legend"])
        )
        viewer[f"{root}/bar"].set_transform(bar)
        sent.append(f"{root}/bar")
    width = 0.5 * size  # the plane's side; the text runs across its middle

    def lower(self: Any, _: Any) -> dict[str, Any]:
        return {"uuid": self.uuid, "type": "PlaneGeometry", "width": width, "height": width}

    plane = type("TextPlane", (mg.Geometry,), {"lower": lower})
    facing = np.eye(4)
    facing[:3, :3] = np.column_stack([right, up, CAMERA])
    for k, line in enumerate(lines):
        texture = mg.GenericTexture(
            {"type": "_text", "text": line, "font_size": 20, "font_face": "sans-serif"}
        )
        material = mg.MeshBasicMaterial(map=texture, transparent=True, alphaTest=0.1, side=2)
        path = f"{root}/lines/{k}"
        viewer[path].set_object(plane(), material)
        at = facing.copy()
        at[:3, 3] = anchor + 0.5 * width * right - (0.04 + 0.045 * k) * size * up
        viewer[path].set_transform(at)
        sent.append(path)
    return sent


def _aim_camera(viewer: Any, bones: Skeleton, root: str) -> None:
    """Hide meshcat's 1 m axes and grid, move the mechanism's centre to the origin the camera
    orbits (its root node shifted), and look at it from 1.2 times its size away, from the side of
    :data:`CAMERA` (three.js axes, y up)."""
    viewer["/Axes"].set_property("visible", False)
    viewer["/Grid"].set_property("visible", False)
    # a light background: the legend's black text and bar read on it (meshcat's is dark)
    viewer["/Background"].set_property("top_color", [1.0, 1.0, 1.0])
    viewer["/Background"].set_property("bottom_color", [0.88, 0.9, 0.94])
    shift = np.eye(4)
    shift[:3, 3] = -centre(bones)
    viewer[root].set_transform(shift)
    x, y, z = 1.2 * bones.size() * CAMERA  # the size and its legend below fill the view
    viewer["/Cameras/default/rotated/<object>"].set_property("position", [x, z, -y])


def _name(text: str) -> str:
    """A scene path entry: letters, digits, ``_``, ``-`` and ``.`` kept, the rest ``_``."""
    return re.sub(r"[^A-Za-z0-9_.\-]+", "_", text).strip("_")

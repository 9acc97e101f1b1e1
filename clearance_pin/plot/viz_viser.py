"""The viser backend of :func:`~clearance_pin.plot.viz.show_equilibrium` (the ``viser`` extra:
``pip install clearance_pin[viser]``; imported only when such a view is served).

viser (and Pinocchio's ``ViserVisualizer``) places scene nodes by rigid placements (a position and
a quaternion) and a per-axis scale; the magnified settled pose moves each part by the affine map of
:func:`~clearance_pin.plot.viz.magnified_motion`, which is not rigid. So each part is sent as its
vertices already mapped: its geometry (the URDF's mesh file read with trimesh, or the primitive:
box, sphere, cylinder, capsule, cone, convex) in its own frame, taken through
:func:`~clearance_pin.plot.viz.part_matrix` to world [m], in a node at the identity. Every vertex
is where the meshcat view and the pictures put it: :math:`p_0 + m (R p_0 + t - p_0)`. Nothing is
approximated by a rigid placement. The skeleton (settled links, joint centres, play, contact and
applied forces) is drawn with viser's line segments and spheres; the legend is a panel of the
page's controls, and the scale bar a black segment with a label in the scene.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import warnings
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..equilibrium.result import Equilibrium
from ..errors import ClearancePinError, ClearancePinWarning
from .skeleton import FloatArray, Skeleton, force_arrows, magnify, play_segments
from .viz import (
    CAMERA,
    COLOURS,
    FORCE_FRACTION,
    View,
    _largest_play,
    _name,
    _screen_axes,
    centre,
    legend_anchor,
    part_matrix,
    scale_legend,
)

if TYPE_CHECKING:
    from ..mechanism import Mechanism


def show_viser(
    equilibrium: Equilibrium,
    bones: Skeleton,
    m: float,
    geometry: Any,
    port: int | None,
    open_browser: bool,
    show_skeleton: bool,
) -> View:
    """Serve the magnified settled pose with viser (see the module); the arguments are
    :func:`~clearance_pin.plot.viz.show_equilibrium`'s, checked there."""
    try:
        viser = importlib.import_module("viser")
        trimesh = importlib.import_module("trimesh")
    except ImportError:
        raise ClearancePinError(
            "the viser view needs viser: pip install clearance_pin[viser]"
        ) from None
    mechanism = cast("Mechanism", equilibrium.mechanism)
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=8080 if port is None else int(port))
    root = "/" + (_name(str(mechanism.name)) or "mechanism")
    handles: dict[str, Any] = {}
    meshes = geometry is not None and len(geometry.geometryObjects) > 0
    try:
        if meshes:
            for obj in geometry.geometryObjects:
                mesh = _local_mesh(trimesh, obj)
                if mesh is None:
                    continue
                mesh.apply_transform(part_matrix(equilibrium, obj, m))
                path = f"{root}/visuals/{_name(obj.name)}"
                colour = np.asarray(obj.meshColor, dtype=float)
                textured = bool(obj.meshPath) and not obj.overrideMaterial
                if textured and getattr(mesh.visual, "kind", None) is not None:
                    handles[path] = server.scene.add_mesh_trimesh(path, mesh)
                else:
                    handles[path] = server.scene.add_mesh_simple(
                        path,
                        np.asarray(mesh.vertices),
                        np.asarray(mesh.faces),
                        color=tuple(int(255 * c) for c in colour[:3]),
                        opacity=None if colour[3] >= 1.0 else float(colour[3]),
                    )
        if show_skeleton or not meshes:
            handles.update(_skeleton(server, bones, m, f"{root}/skeleton"))
        legend, bar = scale_legend(m, bones.size(), _largest_play([bones]), meshes)
        handles.update(_legend(server, legend, m * bar, bones, f"{root}/legend"))
        middle = centre(bones)
        camera = middle + 2.0 * bones.size() * CAMERA  # as meshcat's first camera
        server.initial_camera.position = tuple(float(v) for v in camera)
        server.initial_camera.look_at = tuple(float(v) for v in middle)
        server.initial_camera.up = (0.0, 0.0, 1.0)
    except BaseException:
        server.stop()
        raise
    url = f"http://127.0.0.1:{server.get_port()}"
    view = View(
        url, m, meshes, tuple(handles), server, legend, bar, backend="viser",
        handles=handles, stop=server.stop,
    )  # fmt: skip
    if open_browser:
        import webbrowser

        webbrowser.open(url)
    return view


def _local_mesh(trimesh: Any, obj: Any) -> Any:
    """The visual object's geometry as a ``trimesh.Trimesh`` in its own frame (mesh units: its
    ``meshScale`` is applied by ``part_matrix``), or None for a kind not drawn."""
    coal = importlib.import_module("coal")
    geom = obj.geometry
    if isinstance(geom, coal.Box):
        return trimesh.creation.box(extents=2.0 * np.asarray(geom.halfSide))
    if isinstance(geom, coal.Sphere):
        return trimesh.creation.icosphere(subdivisions=3, radius=geom.radius)
    if isinstance(geom, coal.Cylinder):
        return trimesh.creation.cylinder(radius=geom.radius, height=2.0 * geom.halfLength)
    if isinstance(geom, coal.Capsule):
        return trimesh.creation.capsule(height=2.0 * geom.halfLength, radius=geom.radius)
    if isinstance(geom, coal.Cone):
        cone = trimesh.creation.cone(radius=geom.radius, height=2.0 * geom.halfLength)
        cone.apply_translation([0.0, 0.0, -geom.halfLength])  # centred, as coal's
        return cone
    if obj.meshPath:
        try:
            return trimesh.load(obj.meshPath, force="mesh")
        except (ImportError, ValueError, OSError) as exc:  # a format trimesh cannot read here
            warnings.warn(
                f"{obj.meshPath}: not shown ({exc}); a COLLADA (.dae) mesh needs pycollada: "
                "pip install clearance_pin[viser]",
                ClearancePinWarning,
                stacklevel=4,
            )
            return None
    if isinstance(geom, coal.ConvexBase):
        points = np.asarray(geom.points())
        faces = np.array([[geom.polygons(k)[i] for i in range(3)]
                          for k in range(geom.num_polygons)])  # fmt: skip
        return trimesh.Trimesh(points, faces)
    return None


def _skeleton(server: Any, bones: Skeleton, m: float, root: str) -> dict[str, Any]:
    """The skeleton as line segments and spheres under ``root``; by path, their handles."""
    handles: dict[str, Any] = {}
    size = bones.size()

    def lines(
        path: str, pairs: list[tuple[FloatArray, FloatArray]], colour: int, width: float
    ) -> None:
        if pairs:
            handles[path] = server.scene.add_line_segments(
                path, np.array(pairs, dtype=np.float32), _rgb(colour), thickness=width,
                thickness_units="screen",
            )  # fmt: skip

    drawn = magnify(bones.points, bones.moved, m)
    lines(f"{root}/nominal", [(bones.points[a], bones.points[b]) for a, b in bones.links],
          COLOURS["nominal"], 1.5)  # fmt: skip
    lines(
        f"{root}/settled", [(drawn[a], drawn[b]) for a, b in bones.links], COLOURS["settled"], 4.0
    )
    for joint in bones.joints:
        path = f"{root}/joints/{_name(joint.name)}"
        handles[path] = server.scene.add_icosphere(
            path, radius=0.008 * size, color=_rgb(COLOURS["settled"]),
            position=tuple(float(v) for v in magnify(joint.journal, joint.journal_moved, m)),
        )  # fmt: skip
        lines(f"{root}/play/{_name(joint.name)}", play_segments(joint, m), COLOURS["play"], 1.5)
    for group, label, segment in force_arrows(bones, m, FORCE_FRACTION):
        colour = COLOURS["contact" if group == "contacts" else "load"]
        lines(f"{root}/{group}/{_name(label)}", [segment], colour, 2.0)
    return handles


def _legend(
    server: Any, legend: tuple[str, ...], bar_drawn: float, bones: Skeleton, root: str
) -> dict[str, Any]:
    """The legend as a panel of the page's controls, the scale bar (``bar_drawn`` [m] long) as
    a black segment with its label in the scene."""
    right, _ = _screen_axes()
    anchor = legend_anchor(bones)
    end = anchor + bar_drawn * right
    handles = {
        f"{root}/bar": server.scene.add_line_segments(
            f"{root}/bar", np.array([[anchor, end]], dtype=np.float32), (0, 0, 0),
            thickness=4.0, thickness_units="screen",
        ),
        f"{root}/bar_label": server.scene.add_label(
            f"{root}/bar_label", legend[1], position=tuple(float(v) for v in 0.5 * (anchor + end))
        ),
        "gui/legend": server.gui.add_markdown("  \n".join(legend)),
    }  # fmt: skip
    return handles


def _rgb(colour: int) -> tuple[int, int, int]:
    return (colour >> 16) & 0xFF, (colour >> 8) & 0xFF, colour & 0xFF

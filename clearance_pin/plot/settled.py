"""The picture of a settled pose: the mechanism at its nominal pose and settled in its clearances.

:func:`plot_equilibrium` draws the skeleton (:mod:`.skeleton`) twice: at the nominal pose (grey,
dashed) and at the settled pose with every displacement magnified by one factor (blue), with each
joint's play to scale at that magnification (a circle of radius m c around the housing's centre for
a pin, a journal's two end circles, a guide's band of half-width m c), each active contact as a dot
on the child part with the housing's force on it (an arrow ending at the contact), and the applied
point forces (arrows starting at their point), all forces at one stated scale. A planar mechanism
is drawn in its plane; a spatial one in 3-D from two views. Positions in mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..equilibrium.result import Equilibrium
from ..errors import ArgumentError
from . import style
from .skeleton import (
    CIRCLE,
    FloatArray,
    JointMark,
    Skeleton,
    magnify,
    plane_axes,
    play_outlines,
    skeleton,
)

MM = 1e3  # drawing unit: mm per m
FORCE_FRACTION = 0.15  # the largest force drawn at about 15 % of the mechanism's size
SEPARATE = 0.2  # applied forces below this share of the largest contact force: a scale of their own
VIEWS = ((22.0, -58.0), (22.0, 32.0))  # (elevation, azimuth) [deg] of the two 3-D views
FORMULATIONS = {"linear": "small-displacement model", "exact": "exact model"}

CONTACT_FORCE = "contact-force"  # gid of every contact force arrow (one per active contact)
LOAD_FORCE = "load-force"  # gid of every applied force arrow
PLAY = "play"  # gid of every play outline
#: a play outline drawn smaller than this fraction of the drawing is said to be invisible
UNSEEN_PLAY = 0.003
CONTACT_LABEL = "contact point (moving part)"
CONTACT_FORCE_LABEL = "contact force (housing on part)"
LOAD_LABEL = "applied force"


def plot_equilibrium(
    equilibrium: Equilibrium,
    path: str | Path | None = None,
    magnification: float | None = None,
    *,
    force_scale: float | None = None,
    labels: bool = True,
    title: str | None = None,
) -> Any:
    """Draw ``equilibrium``'s nominal and settled poses; returns the matplotlib Figure.

    Args:
        equilibrium: an :class:`~clearance_pin.equilibrium.result.Equilibrium` of either
            formulation.
        path: also write the picture there (PNG, PDF or SVG by its suffix).
        magnification: factor m on every displacement and play (default: a round number that
            draws the largest displacement at about 5 % of the mechanism's size,
            :meth:`.skeleton.Skeleton.default_magnification`); stated in the title.
        force_scale: forces drawn at this many newtons per mm of arrow [N/mm] (default: a round
            number that draws the largest force at about 15 % of the size); stated in the title.
        labels: name the joints and number the output points.
        title: replaces the first line of the title (the model and formulation).

    Returns:
        ``matplotlib.figure.Figure`` (not registered with pyplot: nothing to close).

    Raises:
        ClearancePinError: matplotlib is missing (``pip install clearance_pin[plot]``).
        ArgumentError: a magnification or force scale that is not a positive number.
    """
    bones = skeleton(equilibrium)
    m = bones.default_magnification() if magnification is None else float(magnification)
    if not np.isfinite(m) or m <= 0.0:
        raise ArgumentError("magnification", "a positive number", magnification)
    if force_scale is not None and (not np.isfinite(force_scale) or force_scale <= 0.0):
        raise ArgumentError("force_scale", "a positive number of N per mm", force_scale)
    arrow = _scales(bones, force_scale)
    normal = bones.plane()
    if normal is not None:
        figure = style.new_figure(12.0, _planar_height(bones, normal, m))
        ax = figure.add_subplot(1, 1, 1)
        _planar(ax, bones, normal, m, arrow, labels)
        _legends(ax, [ax], bones, labels)
    else:
        figure = style.new_figure(17.0, 8.0)
        figure.get_layout_engine().set(wspace=0.08)
        axes = [figure.add_subplot(1, 2, k + 1, projection="3d") for k in range(2)]
        for k, (ax, (elevation, azimuth)) in enumerate(zip(axes, VIEWS)):
            _spatial(ax, bones, m, arrow, labels and k == 0, elevation, azimuth)
        _legends(axes[-1], axes[:1], bones, labels)
    largest = bones.largest_displacement()
    first = title or (
        f"{bones.name}: settled pose in the joint clearances"
        f"{' and springs' if equilibrium.deflections else ''} "
        f"({FORMULATIONS.get(bones.formulation, bones.formulation)})"
    )
    notes = [f"displacements and play drawn x{style.number(m)}"]
    notes.append(f"largest displacement {largest * 1e6:.3g} um")
    notes.append(arrow.text())
    if bones.torques or bones.gravity:
        also = [f"torque on {', '.join(bones.torques)}"] if bones.torques else []
        also += ["gravity"] if bones.gravity else []
        notes.append(f"also loaded (not drawn): {', '.join(also)}")
    figure.suptitle(f"{first}\n{'; '.join(notes)}", fontsize=11)
    style.save(figure, path)
    return figure


@dataclass(frozen=True)
class _Scales:
    """Force scales of the arrows [N per mm]: contact forces and applied forces."""

    contact: float
    load: float

    def text(self) -> str:
        if self.contact == self.load:
            return f"forces: 1 mm = {style.number(self.contact)} N"
        return (
            f"contact forces: 1 mm = {style.number(self.contact)} N, "
            f"applied forces: 1 mm = {style.number(self.load)} N"
        )


def _scales(bones: Skeleton, given: float | None) -> _Scales:
    """``given`` for every arrow, or round N per mm drawing the largest force at about
    FORCE_FRACTION of the size: one scale for all, unless the applied forces would be drawn
    at less than SEPARATE of the largest contact force (a robot's bearings carrying moments
    of a small tool force), when they get a scale of their own."""
    if given is not None:
        return _Scales(float(given), float(given))
    reach = FORCE_FRACTION * bones.size() * MM
    contact = max((float(np.linalg.norm(c.force)) for c in bones.active_contacts), default=0.0)
    load = max((float(np.linalg.norm(f.force)) for f in bones.loads), default=0.0)
    largest = max(contact, load)
    common = style.nice_ceil(largest / reach) if largest > 0.0 else 1.0
    if load > 0.0 and contact > 0.0 and load < SEPARATE * contact:
        return _Scales(common, style.nice_ceil(load / reach))
    return _Scales(common, common)


class _Projection:
    """World points [m] to drawing coordinates [mm]: the plane's two axes, or all three."""

    def __init__(self, basis: FloatArray) -> None:
        self.basis = basis  # (3, k)

    def __call__(self, points: FloatArray) -> FloatArray:
        return np.asarray(np.atleast_2d(points) @ self.basis * MM, dtype=float)

    def vector(self, force: FloatArray) -> FloatArray:
        """A force [N] in the drawing's axes (its components, not scaled)."""
        return np.asarray(force @ self.basis, dtype=float)


def _planar(
    ax: Any, bones: Skeleton, normal: FloatArray, m: float, arrow: _Scales, labels: bool
) -> None:
    from matplotlib.patches import FancyArrowPatch

    e1, e2, name1, name2 = plane_axes(normal)
    project = _Projection(np.column_stack([e1, e2]))
    drawn = magnify(bones.points, bones.moved, m)
    nominal, settled = project(bones.points), project(drawn)
    _links(ax, bones, nominal, settled)
    for joint in bones.joints:
        _play_planar(ax, bones, joint, project, m, normal)
    _joint_centres(ax, bones, project, m)
    for contact in bones.active_contacts:
        at = project(magnify(contact.point, contact.moved, m))[0]
        ax.plot(*at, "o", color=style.CONTACT, ms=4.5, zorder=6, label=CONTACT_LABEL)
        tail = at - project.vector(contact.force) / arrow.contact
        ax.add_patch(
            FancyArrowPatch(
                tuple(tail), tuple(at), arrowstyle="-|>", mutation_scale=11, lw=1.4,
                color=style.CONTACT, zorder=5, gid=CONTACT_FORCE, shrinkA=0, shrinkB=0,
                label=CONTACT_FORCE_LABEL,
            )
        )  # fmt: skip
    for load in bones.loads:
        at = project(magnify(load.point, load.moved, m))[0]
        head = at + project.vector(load.force) / arrow.load
        ax.add_patch(
            FancyArrowPatch(
                tuple(at), tuple(head), arrowstyle="-|>", mutation_scale=11, lw=1.4,
                color=style.LOAD, zorder=5, gid=LOAD_FORCE, shrinkA=0, shrinkB=0,
                label=LOAD_LABEL,
            )
        )  # fmt: skip
    _outputs_planar(ax, bones, project, m, labels)
    if labels:
        _joint_labels(ax, bones, project)
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.margins(0.08)
    ax.set_xlabel(f"{name1} [mm]")
    ax.set_ylabel(f"{name2} [mm]")
    ax.grid(True, alpha=0.3)


def _planar_height(bones: Skeleton, normal: FloatArray, m: float) -> float:
    """Figure height [in] for a 12 in wide planar picture: the drawing's aspect, within 4.5-9."""
    e1, e2, _, _ = plane_axes(normal)
    drawn = np.vstack([bones.points, magnify(bones.points, bones.moved, m)])
    span = np.ptp(drawn @ np.column_stack([e1, e2]), axis=0)
    ratio = float(span[1] / span[0]) if span[0] > 0 else 1.0
    return float(np.clip(8.0 * ratio + 2.0, 4.5, 9.0))


def _play_label(bones: Skeleton, m: float) -> str:
    """The play's legend entry with the radii drawn [mm]."""
    radii = sorted({round(m * j.radial * MM, 3) for j in bones.joints if j.radial > 0.0})
    if not radii:
        return "joint play (to scale, magnified)"
    drawn = f"{radii[0]:g}" if len(radii) == 1 else f"{radii[0]:g}-{radii[-1]:g}"
    label = f"joint play, to scale (c x{style.number(m)}: {drawn} mm)"
    span = float(np.ptp(bones.points, axis=0).max()) * MM  # the drawing's size [mm]
    if radii[-1] < UNSEEN_PLAY * span:  # say why the entry has nothing to point at
        label += ",\n  too small to see at this size"
    return label


def _links(ax: Any, bones: Skeleton, nominal: FloatArray, settled: FloatArray) -> None:
    for a, b in bones.links:
        ground = bones.bodies[a] == 0
        if ground:
            ax.plot(*np.column_stack([nominal[a], nominal[b]]), "-", color=style.GROUND, lw=5,
                    alpha=0.35, solid_capstyle="round", zorder=1, label="ground (fixed)")  # fmt: skip
            continue
        ax.plot(*np.column_stack([nominal[a], nominal[b]]), "--", color=style.NOMINAL, lw=1.2,
                zorder=2, label="nominal pose")  # fmt: skip
        ax.plot(*np.column_stack([settled[a], settled[b]]), "-", color=style.SETTLED, lw=2.2,
                alpha=0.85, solid_capstyle="round", zorder=3, label="settled pose (magnified)")  # fmt: skip


def _joint_centres(ax: Any, bones: Skeleton, project: _Projection, m: float) -> None:
    """Nominal joint centres (grey rings), settled housing centres (crosses) and journal
    centres (dots)."""
    for joint in bones.joints:
        ax.plot(*project(joint.housing)[0], "o", ms=7, mfc="none", mec=style.NOMINAL, mew=1.0,
                zorder=2, label="joint, nominal centre")  # fmt: skip
        housing = project(magnify(joint.housing, joint.housing_moved, m))[0]
        journal = project(magnify(joint.journal, joint.journal_moved, m))[0]
        ax.plot(*housing, "+", ms=7, color=style.PLAY, mew=1.2, zorder=4,
                label="housing centre (settled)")  # fmt: skip
        ax.plot(*journal, "o", ms=4, color=style.SETTLED, zorder=4,
                label="journal / pin centre (settled)")  # fmt: skip


def _play_planar(
    ax: Any, bones: Skeleton, joint: JointMark, project: _Projection, m: float, normal: FloatArray
) -> None:
    """The joint's play to scale (x m) around its settled housing: a circle for a pin or
    journal seen along its axis, a band along a guide."""
    if not joint.has_play:
        return
    centre = magnify(joint.housing, joint.housing_moved, m)
    label = _play_label(bones, m)
    if joint.kind in ("planar_revolute", "revolute", "cylindrical", "spherical"):
        y, z = joint.axes[:, 1], joint.axes[:, 2]
        ring = centre + m * joint.radial * (
            np.outer(np.cos(CIRCLE), y) + np.outer(np.sin(CIRCLE), z)
        )
        if joint.kind == "spherical":
            ring = centre + m * joint.radial * _in_plane_circle(normal)
        (line,) = ax.plot(*project(ring).T, "-", color=style.PLAY, lw=1.2, zorder=3, label=label)
        line.set_gid(PLAY)
    elif joint.kind == "prismatic":
        across = np.cross(normal, joint.axis)
        y_share = abs(float(across @ joint.axes[:, 1]))
        play = joint.radial if y_share > 0.5 else joint.play_z
        half = 0.5 * max(joint.length, 1e-9)
        for side in (-1.0, 1.0):
            ends = centre + np.outer([-half, half], joint.axis) + side * m * play * across
            (line,) = ax.plot(*project(ends).T, "-", color=style.PLAY, lw=1.2, zorder=3,
                              label=label)  # fmt: skip
            line.set_gid(PLAY)


def _in_plane_circle(normal: FloatArray) -> FloatArray:
    e1, e2, _, _ = plane_axes(normal)
    return np.asarray(np.outer(np.cos(CIRCLE), e1) + np.outer(np.sin(CIRCLE), e2), dtype=float)


def _outputs_planar(ax: Any, bones: Skeleton, project: _Projection, m: float, labels: bool) -> None:
    for index, (places, _) in enumerate(_output_groups(bones)):
        at = project(magnify(places[0].point, places[0].moved, m))[0]
        ax.plot(*at, "x", color=style.OUTPUT, ms=7, mew=1.5, zorder=7, label="output point")
        if labels:
            ax.annotate(str(index + 1), at, textcoords="offset points", xytext=(5, -11),
                        fontsize=8, color=style.OUTPUT, zorder=8)  # fmt: skip


def _output_groups(bones: Skeleton) -> list[tuple[list[Any], str]]:
    """Output points grouped by place (one mark for frames at one point), with their text."""
    groups: list[tuple[list[Any], str]] = []
    tolerance = 1e-9 * bones.size()
    for output in bones.outputs:
        text = f"{output.name}: {output.displacement * 1e6:.4g} um"
        for places, _ in groups:
            if np.linalg.norm(places[0].point - output.point) <= tolerance:
                places.append(output)
                break
        else:
            groups.append(([output], text))
    return [
        (places, "\n     ".join(f"{o.name}: {o.displacement * 1e6:.4g} um" for o in places))
        for places, _ in groups
    ]


def _legends(ax: Any, drawn: list[Any], bones: Skeleton, numbered: bool) -> None:
    """Beside ``ax``: what each mark means (the entries of ``drawn``, each once; arrows by an
    arrow), and under it the outputs' displacements numbered as their marks."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyArrowPatch

    seen: dict[str, Any] = {}
    for axes in drawn:
        for handle, label in zip(*axes.get_legend_handles_labels()):
            shown = handle
            if isinstance(handle, FancyArrowPatch) or type(handle).__name__ == "Quiver":
                shown = Line2D([], [], color=handle.get_edgecolor(), lw=1.4, marker=">", ms=6)
            seen.setdefault(label, shown)
    key = ax.legend(list(seen.values()), list(seen), loc="upper left", bbox_to_anchor=(1.03, 1.0),
                    fontsize=8, frameon=False)  # fmt: skip
    groups = _output_groups(bones)
    if not groups:
        return
    ax.add_artist(key)
    handles = [Line2D([], [], ls="none", marker="x", color=style.OUTPUT, mew=1.5) for _ in groups]
    rows = [f"{k + 1 if numbered else ''}  {text}" for k, (_, text) in enumerate(groups)]
    ax.legend(handles, rows, loc="lower left", bbox_to_anchor=(1.03, 0.0), fontsize=8,
              frameon=False, title="output displacement (settled - nominal)", title_fontsize=8,
              alignment="left")  # fmt: skip


def _joint_names(bones: Skeleton) -> list[tuple[FloatArray, str]]:
    """Joint names by nominal centre: joints at one place (a pin and a guide) named together."""
    places: list[tuple[FloatArray, list[str]]] = []
    tolerance = 1e-6 * bones.size()
    for joint in bones.joints:
        for at, names in places:
            if np.linalg.norm(at - joint.housing) <= tolerance:
                names.append(joint.name)
                break
        else:
            places.append((joint.housing, [joint.name]))
    return [(at, " / ".join(names)) for at, names in places]


def _joint_labels(ax: Any, bones: Skeleton, project: _Projection) -> None:
    """Joint names beside their nominal centres, pushed away from the mechanism's middle."""
    middle = project(bones.points).mean(axis=0)
    for place, name in _joint_names(bones):
        at = project(place)[0]
        away = at - middle
        norm = float(np.linalg.norm(away))
        direction = away / norm if norm > 0 else np.array([0.0, 1.0])
        ax.annotate(name, at, textcoords="offset points", xytext=tuple(20 * direction),
                    ha="left" if direction[0] >= 0 else "right",
                    va="bottom" if direction[1] >= 0 else "top", fontsize=8, color="0.3",
                    zorder=8, bbox={"fc": "white", "ec": "none", "alpha": 0.75, "pad": 0.5})  # fmt: skip


def _spatial(
    ax: Any,
    bones: Skeleton,
    m: float,
    arrow: _Scales,
    labels: bool,
    elevation: float,
    azimuth: float,
) -> None:
    project = _Projection(np.eye(3))
    drawn = magnify(bones.points, bones.moved, m)
    nominal, settled = project(bones.points), project(drawn)
    extents = [nominal, settled]
    _links(ax, bones, nominal, settled)
    for joint in bones.joints:
        for ring in play_outlines(joint, m):
            (line,) = ax.plot(*project(ring).T, "-", color=style.PLAY, lw=1.0,
                              label=_play_label(bones, m))  # fmt: skip
            line.set_gid(PLAY)
    _joint_centres(ax, bones, project, m)
    for contact in bones.active_contacts:
        at = project(magnify(contact.point, contact.moved, m))[0]
        force = project.vector(contact.force) / arrow.contact
        ax.plot(*at, "o", color=style.CONTACT, ms=3.5, label=CONTACT_LABEL)
        _arrow3d(ax, at - force, force, style.CONTACT, CONTACT_FORCE, CONTACT_FORCE_LABEL)
        extents.append(np.array([at - force]))
    for load in bones.loads:
        at = project(magnify(load.point, load.moved, m))[0]
        force = project.vector(load.force) / arrow.load
        _arrow3d(ax, at, force, style.LOAD, LOAD_FORCE, LOAD_LABEL)
        extents.append(np.array([at + force]))
    for index, (places, _) in enumerate(_output_groups(bones)):
        at = project(magnify(places[0].point, places[0].moved, m))[0]
        ax.plot(*at, "x", color=style.OUTPUT, ms=7, mew=1.5, label="output point")
        if labels:
            ax.text(*(at + 0.015 * bones.size() * MM), str(index + 1), fontsize=8)
    if labels:
        for place, name in _joint_names(bones):
            at = project(place)[0] + 0.02 * bones.size() * MM
            ax.text(*at, name, fontsize=7, color="0.3")
    _equal_box(ax, np.vstack(extents))
    ax.set_proj_type("ortho")
    ax.view_init(elev=elevation, azim=azimuth)
    ax.set_title(f"view: elevation {elevation:g} deg, azimuth {azimuth:g} deg", fontsize=9)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]", labelpad=8)


def _arrow3d(
    ax: Any, tail: FloatArray, vector: FloatArray, color: str, gid: str, label: str
) -> None:
    quiver = ax.quiver(*tail, *vector, color=color, lw=1.3, arrow_length_ratio=0.18, label=label)
    quiver.set_gid(gid)


def _equal_box(ax: Any, points: FloatArray) -> None:
    """Equal scales on the three axes: limits around the points, box aspect their ranges."""
    low, high = points.min(axis=0), points.max(axis=0)
    span = float(np.max(high - low)) or 1.0
    pad = 0.06 * span
    low, high = low - pad, high + pad
    ranges = np.maximum(high - low, 0.15 * span)
    middle = 0.5 * (low + high)
    low, high = middle - 0.5 * ranges, middle + 0.5 * ranges
    ax.set_xlim(low[0], high[0])
    ax.set_ylim(low[1], high[1])
    ax.set_zlim(low[2], high[2])
    ax.set_box_aspect(tuple(ranges))


def contact_arrows(figure: Any) -> list[Any]:
    """The contact force arrows of a :func:`plot_equilibrium` figure, per axes (one per active
    contact in each view)."""
    return [
        artist
        for ax in figure.axes
        for artist in (*ax.patches, *ax.collections)
        if artist.get_gid() == CONTACT_FORCE
    ]


__all__ = ["plot_equilibrium", "contact_arrows"]

"""Pictures of an accuracy map: the tool's deviation per payload over the poses, where in the
workspace it is largest, and which joint and source moves it (one figure, three panels)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..model.frames import frame_id as find_frame
from ..model.frames import parse_point
from ..plot.style import new_figure, save

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism
    from .accuracy_map import AccuracyMap

UM = 1e6  # [um per m]
MM = 1e3  # [mm per m]
SOURCE_COLOURS = {
    "play": "tab:blue",
    "backlash": "tab:orange",
    "bearing compliance": "tab:green",
    "drive compliance": "tab:red",
}


def plot_accuracy(amap: AccuracyMap, mechanism: Mechanism, path: str | Path | None) -> Any:
    """Draw ``amap`` into ``path`` (PNG, PDF, SVG; None: only return the figure):

    1. the output's deviation |delta p| [um] per payload, its spread over the poses (box: the
       middle half, whiskers: the extremes, line: the median);
    2. the output's nominal position over the poses, top view [mm], coloured by its deviation
       under the heaviest payload: where in the workspace the play shows most;
    3. each joint's largest share of the deviation [um] over the map, by source, largest first.
    """
    figure = new_figure(16.0, 5.2)
    spread, where, sources = figure.subplots(1, 3, gridspec_kw={"width_ratios": [1.0, 1.2, 1.3]})
    norms = np.linalg.norm(amap.translation, axis=2) * UM  # (Q, P)
    _payload_spread(spread, norms, amap.payloads)
    if amap.reach is not None and np.isfinite(amap.reach).any():
        spread.plot(
            range(1, len(amap.payloads) + 1),
            np.nanmax(amap.reach, axis=0) * UM,
            "v",
            color="tab:red",
            label="largest reach (free motions included)",
        )
        top = max(float(np.nanmax(norms)), float(np.nanmax(amap.reach)) * UM)  # [um]
        spread.set_ylim(0.0, 1.15 * top)
        spread.legend(loc="lower right", fontsize="small")  # the boxes rise from zero: room
    _workspace(figure, where, amap, mechanism, norms[:, -1])
    _contributors(sources, amap)
    largest, pose, payload = amap.largest()
    figure.suptitle(
        f"{mechanism.name}: where {amap.output} settles in the joint play"
        f"{' and springs' if any('compliance' in source for source in amap.contributions) else ''}, "
        f"{amap.configurations.shape[0]} poses x {len(amap.payloads)} payloads; largest "
        f"{largest * UM:.1f} um (pose {pose}, {amap.payloads[payload]})"
    )
    save(figure, path)
    return figure


def plot_workspace(
    amap: AccuracyMap, mechanism: Mechanism, path: str | Path | None, payload: int = -1
) -> Any:
    """Draw the output's deviation over the workspace into ``path`` (PNG, PDF, SVG; None: only
    return the figure): its nominal positions [mm], world frame, seen from above (x, y) and from
    the side (x, z), coloured by |delta p| [um] under payload ``payload`` (default the last);
    where the reach was computed, a second row colours the same points by the band, reach minus
    deviation [um]: how much farther the motions the load leaves free can take it."""
    label = amap.payloads[payload]
    norms = np.linalg.norm(amap.translation[:, payload], axis=1) * UM
    reach = None if amap.reach is None else amap.reach[:, payload] * UM
    with_reach = reach is not None and bool(np.isfinite(reach).any())
    figure = new_figure(12.0, 9.6 if with_reach else 5.0)
    axes = figure.subplots(2 if with_reach else 1, 2, squeeze=False)
    points = _positions(amap, mechanism) * MM
    values = [("deviation |delta p|", norms)]
    if with_reach:
        assert reach is not None
        values.append(("band: reach - |delta p|", reach - norms))
    for row, (name, value) in enumerate(values):
        top = float(np.nanmax(value)) if np.isfinite(value).any() else 1.0
        order = np.argsort(np.nan_to_num(value, nan=-1.0))  # the largest drawn last, on top
        for column, (a, b, view) in enumerate(((0, 1, "top view"), (0, 2, "side view"))):
            ax = axes[row, column]
            drawn = ax.scatter(points[order, a], points[order, b], c=value[order], s=10,
                               cmap="viridis", vmin=0.0, vmax=max(top, 1e-3))  # fmt: skip
            ax.set_xlabel(f"{'xyz'[a]} [mm] (world)")
            ax.set_ylabel(f"{'xyz'[b]} [mm] (world)")
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_title(f"{name}, {view}")
            ax.grid(alpha=0.3)
            bar = figure.colorbar(drawn, ax=ax)
            bar.set_label(f"{name} of {amap.output} [um]")
    where = (
        ""
        if amap.payload_point is None
        else (
            f" at ({', '.join(f'{v * MM:g}' for v in amap.payload_point)}) mm in {amap.output}'s frame"
        )
    )
    figure.suptitle(
        f"{mechanism.name}: {amap.output}'s deviation over {amap.configurations.shape[0]} poses, "
        f"payload {label}{where}; positions and displacements in the world frame"
    )
    save(figure, path)
    return figure


def _positions(amap: AccuracyMap, mechanism: Mechanism) -> np.ndarray:
    """The output's nominal position at every pose, (Q, 3) [m], world frame."""
    model = mechanism.model
    data = model.createData()
    parsed = parse_point(amap.output)  # a point of a link, link@[x y z], or a frame
    name, local = (amap.output, np.zeros(3)) if parsed is None else parsed
    frame = find_frame(model, name)
    points = np.empty((amap.configurations.shape[0], 3))
    for i, q in enumerate(amap.configurations):
        pin.framesForwardKinematics(model, data, q)
        points[i] = data.oMf[frame].act(local)
    return points


def _payload_spread(ax: Any, norms: np.ndarray, labels: tuple[str, ...]) -> None:
    finite = [column[np.isfinite(column)] for column in norms.T]
    ax.boxplot(finite, whis=(0, 100), widths=0.6)
    ax.set_xticks(range(1, len(labels) + 1), labels, rotation=30, ha="right")
    ax.set_xlabel("payload")
    ax.set_ylabel("deviation of the output |delta p| [um]")
    ax.set_title("per payload, over the poses\n(box: middle half, whiskers: extremes)")
    ax.set_ylim(bottom=0.0)
    ax.grid(axis="y", alpha=0.3)


def _workspace(
    figure: Any, ax: Any, amap: AccuracyMap, mechanism: Mechanism, norms: np.ndarray
) -> None:
    points = _positions(amap, mechanism)
    order = np.argsort(np.nan_to_num(norms, nan=-1.0))  # the largest drawn last, on top
    drawn = ax.scatter(
        points[order, 0] * MM, points[order, 1] * MM, c=norms[order], s=12, cmap="viridis"
    )
    colour_bar = figure.colorbar(drawn, ax=ax)
    colour_bar.set_label(f"deviation under {amap.payloads[-1]} [um]")
    ax.set_xlabel("x [mm] (world)")
    ax.set_ylabel("y [mm] (world)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"{amap.output}'s nominal position, top view")
    ax.grid(alpha=0.3)


def _contributors(ax: Any, amap: AccuracyMap) -> None:
    ranking = amap.ranking()
    joints = list(dict.fromkeys(joint for _, joint, _ in ranking))
    positions = np.arange(len(joints))
    sources = [s for s in SOURCE_COLOURS if any(r[0] == s for r in ranking)]
    width = 0.8 / max(len(sources), 1)
    for k, source in enumerate(sources):
        values = [
            next((v for s, j, v in ranking if s == source and j == joint), 0.0) * UM
            for joint in joints
        ]
        ax.barh(
            positions + (k - (len(sources) - 1) / 2) * width,
            values,
            height=width,
            color=SOURCE_COLOURS[source],
            label=source,
        )
    ax.set_yticks(positions, joints)
    ax.invert_yaxis()  # the largest on top
    ax.set_xlabel("largest share of the deviation over the map [um]")
    ax.set_title("which joint moves the output, by source")
    ax.legend(loc="lower right")
    ax.grid(axis="x", alpha=0.3)


__all__ = ["plot_accuracy", "plot_workspace"]

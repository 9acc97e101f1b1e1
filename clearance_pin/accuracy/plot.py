"""Pictures of an accuracy map: the tool's deviation per payload over the poses, where in the
workspace it is largest, and which joint and source moves it (one figure, three panels)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..plot.style import new_figure, save

if TYPE_CHECKING:
    from ..mechanism import Mechanism
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
    model = mechanism.model
    data = model.createData()
    frame = model.getFrameId(amap.output)
    points = np.empty((amap.configurations.shape[0], 3))
    for i, q in enumerate(amap.configurations):
        pin.framesForwardKinematics(model, data, q)
        points[i] = data.oMf[frame].translation
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


__all__ = ["plot_accuracy"]

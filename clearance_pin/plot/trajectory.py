"""Pictures along a trajectory: an :class:`~clearance_pin.equilibrium.batch.EquilibriumBatch` of
``solve_many(configurations=...)`` against the driven joint's value.

:func:`plot_trajectory` draws, sharing the abscissa (the driven joint in deg, or mm for a
prismatic joint): the outputs' deviation (length of the translation [um]), the contact forces [N]
and the contact modes, one row per contact point, dark where it touches. A *contact mode* is the
set of touching points, each with its side for a slab contact (the two faces of a guide, the two
shoulders of an axial play, the two stops of a drive's backlash); where it changes along the
trajectory (:func:`contact_modes`) the panels are shaded in alternate bands and the change is
marked.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt

from ..equilibrium.batch import EquilibriumBatch
from ..equilibrium.result import Equilibrium
from ..errors import ArgumentError, ClearancePinError, NotFoundError
from ..model.clearance import ALPHA, U
from ..model.joints import MOTION_COMPONENT_BY_PIN_JOINT
from . import style

if TYPE_CHECKING:
    from ..mechanism import Mechanism

FloatArray = npt.NDArray[np.float64]

BACKLASH_STOP = "backlash"  # the contact point of a drive's lost motion (model.clearance)
MAX_FORCE_LINES = 10  # more contact points than this: one line per joint (its largest contact)
BAND = "0.92"  # shading of every other contact mode


@dataclass(frozen=True)
class ContactModes:
    """The contact modes along a batch.

    Attributes:
        labels: every contact point that touches somewhere (``joint:point``), in model order.
        touching: per case and label, 0 free, +1 / -1 touching (the face a slab contact rests
            on: the sign of its displacement along the bounded axis, opposite to its force; for
            a drive's backlash stop the sign of its turn, opposite to the stop's moment about
            the axis; +1 for a ball or disc), (N, len(labels)); NaN for a failed case.
        modes: per case, the index of its mode (its touching set) in order of appearance; -1
            for a failed case.
        changes: indices i where case i's mode differs from case i - 1's, or where a ball, disc
            or journal-end contact's force turns by more than 90 deg from case i - 1's (the part
            flips across its play: :attr:`flips`); failed cases skipped.
        flips: per change in :attr:`changes` made by such a turn, (i, the contacts that turned).
        stops: per change in :attr:`changes` where a drive's backlash stop switches side (the
            joint's load torque changed sign: the joint crosses its whole backlash at once),
            (i, the stops that switched).
    """

    labels: tuple[str, ...]
    touching: FloatArray
    modes: npt.NDArray[np.int64]
    changes: tuple[int, ...]
    flips: tuple[tuple[int, tuple[str, ...]], ...] = ()
    stops: tuple[tuple[int, tuple[str, ...]], ...] = ()


def contact_modes(batch: Sequence[Equilibrium | Exception]) -> ContactModes:
    """The contact modes of every case of ``batch`` and where they change (see the module)."""
    items = list(batch)
    valid = [item for item in items if isinstance(item, Equilibrium)]
    if not valid:
        raise ClearancePinError("the batch has no equilibrium (every case failed)")
    mechanism = cast("Mechanism", valid[0].mechanism)
    shapes = _contact_shapes(mechanism)
    labels = tuple(
        c.label for c in valid[0].contacts if any(_touches(item, c.label) for item in valid)
    )
    touching = np.full((len(items), len(labels)), np.nan)
    for i, item in enumerate(items):
        if isinstance(item, Equilibrium):
            by_label = {c.label: c for c in item.contacts}
            for k, label in enumerate(labels):
                contact = by_label[label]
                touching[i, k] = _side(_pushed(contact), shapes[label]) if contact.active else 0.0
    modes = np.full(len(items), -1, dtype=np.int64)
    seen: dict[bytes, int] = {}
    changes: list[int] = []
    flips: list[tuple[int, tuple[str, ...]]] = []
    stops: list[tuple[int, tuple[str, ...]]] = []
    stop_columns = [k for k, label in enumerate(labels) if label.endswith(":" + BACKLASH_STOP)]
    previous: int | None = None
    last_row: FloatArray | None = None
    before: Equilibrium | None = None
    for i, row in enumerate(touching):
        if np.isnan(row).any():
            continue
        mode = seen.setdefault(row.tobytes(), len(seen))
        modes[i] = mode
        item = cast(Equilibrium, items[i])
        turned = () if before is None else flipped(before, item, shapes)
        if turned:
            flips.append((i, turned))
        if previous is not None and (mode != previous or turned):
            changes.append(i)
            assert last_row is not None
            switched = tuple(
                labels[k] for k in stop_columns if row[k] * last_row[k] < 0.0
            )  # touching on both sides: -1 then +1 or +1 then -1
            if switched:
                stops.append((i, switched))
        previous, before, last_row = mode, item, row
    return ContactModes(labels, touching, modes, tuple(changes), tuple(flips), tuple(stops))


def flipped(
    before: Equilibrium, after: Equilibrium, shapes: dict[str, tuple[str, tuple[int, ...]]]
) -> tuple[str, ...]:
    """The ball, disc and journal-end contacts that touch in both answers and whose force turns
    by more than 90 deg from ``before`` to ``after`` (a negative dot product)."""
    forces = {c.label: c.force for c in before.contacts if c.active}
    return tuple(
        c.label
        for c in after.contacts
        if c.active
        and shapes[c.label][0] == "norm"
        and c.label in forces
        and float(np.dot(forces[c.label], c.force)) < 0.0
    )


def _contact_shapes(mechanism: Mechanism) -> dict[str, tuple[str, tuple[int, ...]]]:
    shapes = {}
    for joint in mechanism.joints.values():
        for point in joint.clearance.contacts:
            shapes[f"{joint.name}:{point.name}"] = (str(point.shape), tuple(point.components))
    return shapes


def _touches(item: Equilibrium, label: str) -> bool:
    return any(c.label == label and c.active for c in item.contacts)


def _pushed(contact: Any) -> FloatArray:
    """What a contact transmits, whose sign along the bounded axis tells its side: the force of
    a point contact [N], the moment about the axis of a revolute drive's backlash stop [N m]
    (its force is zero: :attr:`~clearance_pin.equilibrium.result.Contact.moment`)."""
    return np.asarray(contact.force if contact.moment is None else contact.moment, dtype=float)


def _side(force: FloatArray, shape: tuple[str, tuple[int, ...]]) -> float:
    """+1 / -1: the face a slab contact rests on (+1: its displacement is along +y, the face at
    +c, where the housing pushes it towards -y; a backlash stop: turned by +b/2, its moment
    about the axis negative); +1 for a disc or ball. ``force``: :func:`_pushed`."""
    kind, components = shape
    if kind != "abs":
        return 1.0
    value = float(np.asarray(force)[components[0]])
    return 1.0 if value < 0.0 else -1.0


def plot_trajectory(
    batch: EquilibriumBatch | Sequence[Equilibrium | Exception],
    driven_joint: str | None = None,
    outputs: Sequence[str] | None = None,
    path: str | Path | None = None,
    *,
    title: str | None = None,
) -> Any:
    """Draw the outputs' deviation, the contact forces and the contact modes along ``batch``.

    Args:
        batch: the answer of ``mechanism.solve_many(configurations=...)`` (or any sequence of its
            equilibria; failed cases, returned as errors with ``errors="return"``, are marked).
        driven_joint: the joint on the abscissa (default: the driven joint whose value varies
            along the batch; name it when several do).
        outputs: names of the outputs to draw (:attr:`Equilibrium.outputs` keys or Pinocchio
            frame names; default: every output of the first case).
        path: also write the picture there (PNG, PDF or SVG by its suffix).
        title: replaces the first line of the title.

    Returns:
        ``matplotlib.figure.Figure`` (not registered with pyplot: nothing to close).

    Raises:
        ClearancePinError: matplotlib is missing (``pip install clearance_pin[plot]``), or the
            batch holds no equilibrium.
        ArgumentError, NotFoundError: an unknown or unsuitable joint or output.
    """
    items = list(batch)
    valid = [i for i, item in enumerate(items) if isinstance(item, Equilibrium)]
    if not valid:
        raise ClearancePinError("the batch has no equilibrium (every case failed)")
    first = cast(Equilibrium, items[valid[0]])
    mechanism = cast("Mechanism", first.mechanism)
    joint_id = _abscissa_joint(mechanism, items, driven_joint)
    x, unit = _abscissa(mechanism, items, joint_id)
    along_path = bool(np.any(np.diff(x) > 0.0) and np.any(np.diff(x) < 0.0))
    if along_path:  # out and back: the driven joint's value is no abscissa, the path is
        x = np.arange(len(items), dtype=float)
    names = list(first.outputs) if outputs is None else list(outputs)
    deviation = np.full((len(items), len(names)), np.nan)
    for i in valid:
        deviation[i] = [_deviation(cast(Equilibrium, items[i]), name) for name in names]
    modes = contact_modes(items)
    forces, force_labels, per_joint = _forces(items, modes.labels)

    figure = style.new_figure(11.0, 9.0)
    heights = [3.0, 3.0, max(1.2, 0.28 * len(modes.labels) + 0.6)]
    axes = figure.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": heights})
    ok = np.array(valid)
    for k, name in enumerate(names):
        axes[0].plot(x[ok], deviation[ok, k] * 1e6, _dashes(k), label=name, **_width(k))
    axes[0].set_ylabel("output deviation |d| [um]")
    for k, label in enumerate(force_labels):
        axes[1].plot(x[ok], forces[ok, k], _dashes(k), label=label, **_width(k))
    axes[1].set_ylabel("contact force |F| [N]")
    if per_joint:
        axes[1].set_title("largest contact force of each joint", fontsize=9, loc="left")
    _mode_rows(axes[2], x, modes)
    _mode_bands(axes, x, modes)
    failed = [i for i in range(len(items)) if i not in set(valid)]
    if failed:
        axes[0].plot(x[failed], np.zeros(len(failed)), "x", color=style.CONTACT, ms=6,
                     label="no verified equilibrium", clip_on=False)  # fmt: skip
    for ax in axes[:2]:
        ax.grid(True, alpha=0.3)
        ax.set_ylim(bottom=0.0)
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    symbol = "deg" if unit == "rad" else "mm"
    axes[-1].set_xlabel(
        f"point along the path (the {mechanism.model.names[joint_id]} goes and comes back)"
        if along_path
        else f"{mechanism.model.names[joint_id]} [{symbol}]"
    )
    changes = len(modes.changes)
    first_line = title or (
        f"{mechanism.name}: equilibrium along {mechanism.model.names[joint_id]} "
        f"({'exact' if first.formulation == 'exact' else 'small-displacement'} model), "
        f"{len(items)} poses"
    )
    second = (
        f"{changes} contact-mode change{'s' if changes != 1 else ''} (shaded bands, dotted lines)"
        if changes
        else "one contact mode all along (the same contacts touch, on the same sides)"
    )
    if failed:
        second += f"; {len(failed)} poses without a verified equilibrium (x)"
    figure.suptitle(f"{first_line}\n{second}", fontsize=11)
    style.save(figure, path)
    return figure


def _dashes(k: int) -> str:
    """Line style of the k-th curve: colours repeat every 10, styles alternate so that equal
    curves (the two pins of an unloaded link carry one force) stay visible."""
    return ("-", "--", "-.", ":")[k % 4]


def _width(k: int) -> dict[str, float]:
    """Line width and depth of the k-th curve: a curve drawn later is wider and lies below, so
    that one equal to an earlier curve shows around it."""
    return {"lw": 1.3 + 0.5 * (k % 4), "zorder": 3.0 - 0.01 * k}


def _abscissa_joint(
    mechanism: Mechanism, items: list[Equilibrium | Exception], name: str | None
) -> int:
    model: Any = mechanism.model
    if name is not None:
        if not model.existJointName(name) or model.getJointId(name) == 0:
            raise NotFoundError("joint", name, list(model.names)[1:], mechanism.source)
        joint_id = int(model.getJointId(name))
    else:
        driven = [j.joint_id for j in mechanism.tree_joints if j.driven]
        moving = [j for j in driven if np.ptp(_values(model, items, j)) > 0.0]
        if len(moving) != 1:
            names = [model.names[j] for j in (moving or driven)]
            raise ArgumentError(
                "driven_joint",
                "the name of the joint on the abscissa",
                None,
                f"{len(moving)} driven joints move along the batch ({', '.join(names)})",
            )
        joint_id = moving[0]
    if model.joints[joint_id].nv != 1 or _unit(model, joint_id) is None:
        raise ArgumentError("driven_joint", "a revolute or prismatic joint", model.names[joint_id])
    return joint_id


def _unit(model: Any, joint_id: int) -> str | None:
    component = MOTION_COMPONENT_BY_PIN_JOINT.get(model.joints[joint_id].shortname())
    return "rad" if component == ALPHA else "m" if component == U else None


def _values(model: Any, items: list[Equilibrium | Exception], joint_id: int) -> FloatArray:
    """The joint's value in every case [rad or m] (NaN for a failed case)."""
    joint = model.joints[joint_id]
    values = np.full(len(items), np.nan)
    for i, item in enumerate(items):
        if isinstance(item, Equilibrium):
            q = np.asarray(cast(Any, item.configuration).q)
            if joint.nq == 2:
                values[i] = math.atan2(q[joint.idx_q + 1], q[joint.idx_q])
            else:
                values[i] = q[joint.idx_q]
    return values


def _abscissa(
    mechanism: Mechanism, items: list[Equilibrium | Exception], joint_id: int
) -> tuple[FloatArray, str]:
    """The driven joint's value per case: deg (unwrapped) or mm; failed cases interpolated."""
    model: Any = mechanism.model
    unit = _unit(model, joint_id) or "rad"
    values = _values(model, items, joint_id)
    known = np.flatnonzero(~np.isnan(values))
    if unit == "rad":
        values[known] = np.unwrap(values[known])
    if len(known) < len(values):
        index = np.arange(len(values))
        values = np.interp(index, known, values[known])
    return (np.degrees(values) if unit == "rad" else values * 1e3), unit


def _deviation(item: Equilibrium, name: str) -> float:
    """Length of the output's translation [m]: an output of the answer, or a frame."""
    found = item.outputs.get(name)
    if found is None:
        found = item.frame_displacement(name)
    return float(np.linalg.norm(found[0]))


def _forces(
    items: list[Equilibrium | Exception], labels: tuple[str, ...]
) -> tuple[FloatArray, list[str], bool]:
    """|F| per case of every contact that touches somewhere, or, beyond MAX_FORCE_LINES of
    them, the largest of each joint's contacts."""
    per_joint = len(labels) > MAX_FORCE_LINES
    columns = (
        list(dict.fromkeys(label.split(":")[0] for label in labels)) if per_joint else list(labels)
    )
    forces = np.full((len(items), len(columns)), np.nan)
    for i, item in enumerate(items):
        if not isinstance(item, Equilibrium):
            continue
        row = dict.fromkeys(columns, 0.0)
        for contact in item.contacts:
            key = contact.joint if per_joint else contact.label
            if key in row:
                row[key] = max(row[key], contact.force_magnitude)
        forces[i] = list(row.values())
    return forces, columns, per_joint


def _mode_rows(ax: Any, x: FloatArray, modes: ContactModes) -> None:
    """One row per contact point: blue where it touches (a slab contact: on its + face),
    orange where a slab contact touches its - face."""
    edges = _cell_edges(x)
    faces = bool(np.any(modes.touching == -1.0))
    for k in range(len(modes.labels)):
        for side, colour, name in (
            (1.0, style.SETTLED, "touching (a slab contact: its + face)" if faces else "touching"),
            (-1.0, style.PLAY, "touching its - face (slab contact)"),
        ):
            cells = np.flatnonzero(modes.touching[:, k] == side)
            for start, stop in _runs(cells):
                ax.barh(k, edges[stop + 1] - edges[start], left=edges[start], height=0.6,
                        color=colour, label=name, lw=0)  # fmt: skip
    ax.set_yticks(range(len(modes.labels)), modes.labels, fontsize=8)
    ax.set_ylim(len(modes.labels) - 0.5, -0.5)
    ax.set_ylabel("contacts")
    seen: dict[str, Any] = {}
    for handle, label in zip(*ax.get_legend_handles_labels()):
        seen.setdefault(label, handle)
    ax.legend(seen.values(), seen.keys(), fontsize=8, loc="upper left",
              bbox_to_anchor=(1.01, 1.0), frameon=False)  # fmt: skip


def _mode_bands(axes: Any, x: FloatArray, modes: ContactModes) -> None:
    """Every other contact mode shaded on every panel; each change a dotted line."""
    if not modes.changes:
        return
    edges = _cell_edges(x)
    bounds = [0, *modes.changes, len(x)]
    for k in range(len(bounds) - 1):
        if k % 2 == 1:
            for ax in axes:
                ax.axvspan(edges[bounds[k]], edges[bounds[k + 1]], color=BAND, zorder=0, lw=0)
    for change in modes.changes:
        for ax in axes:
            ax.axvline(edges[change], color="0.35", ls=":", lw=1.0, zorder=1)


def _cell_edges(x: FloatArray) -> FloatArray:
    """Edges of the cells around each case (half-way between neighbours), (N + 1,)."""
    if len(x) == 1:
        return np.array([x[0] - 0.5, x[0] + 0.5])
    middle = 0.5 * (x[1:] + x[:-1])
    return np.concatenate([[x[0] - (middle[0] - x[0])], middle, [x[-1] + (x[-1] - middle[-1])]])


def _runs(cells: npt.NDArray[np.int64]) -> list[tuple[int, int]]:
    """Consecutive runs [start, stop] of sorted indices."""
    runs: list[tuple[int, int]] = []
    for cell in cells.tolist():
        if runs and cell == runs[-1][1] + 1:
            runs[-1] = (runs[-1][0], cell)
        else:
            runs.append((cell, cell))
    return runs

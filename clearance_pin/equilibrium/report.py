"""What an engineer reads: an :class:`~.result.Equilibrium` as text tables that keep their columns.

Sections (each states the frame of what it reports):

- *outputs*: the world displacement of every output (loaded points, asked-for frames, leaf links),
  translation [um] and rotation [urad], world axes, with the exact - linear difference and the
  estimate when they exist;
- *bearing loads*: per joint, from its reaction (the wrench the parent part exerts on the child,
  :meth:`~.result.Equilibrium.reaction`, joint's clearance frame, x = joint axis, moment about the
  joint centre): the radial force :math:`\\sqrt{F_y^2 + F_z^2}`, the axial force :math:`F_x`, the
  transverse moment :math:`\\sqrt{M_y^2 + M_z^2}` and the drive torque (or force) of a driven joint;
- *contacts*: gap [um], force [N] (parent on child, clearance frame) and where it acts, in the world
  [mm];
- *joint torsors* (u, v, w [um], alpha, beta, gamma [urad]), clearance frames, and the part of
  them the joints' springs give (joint stiffness);
- residuals, eccentricities, free motions (each once), notes.

Columns are as wide as their longest entry (long joint names, values of 10 mm and more), and a
negative zero is printed as zero.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import ClearancePinError
from ..model.couplings import chain_multipliers

UM = 1e6  # [um per m]
URAD = 1e6  # [urad per rad]
MM = 1e3  # [mm per m]


def columns(
    header: Sequence[str], rows: Sequence[Sequence[str]], first_left: bool = True
) -> list[str]:
    """Lines of a table whose every column is as wide as its widest cell (the first left-aligned,
    the others right-aligned)."""
    widths = [max(len(str(cell)) for cell in column) for column in zip(header, *rows)]

    def line(cells: Sequence[str]) -> str:
        parts = []
        for index, (cell, width) in enumerate(zip(cells, widths)):
            text = str(cell)
            parts.append(text.ljust(width) if index == 0 and first_left else text.rjust(width))
        return "  ".join(parts).rstrip()

    return [line(header), *(line(row) for row in rows)]


def number(value: float, digits: int = 4) -> str:
    """``value`` with ``digits`` decimals, never ``-0.0000``."""
    text = f"{value:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def significant(value: float, floor: float = 0.0) -> str:
    """``value`` to 4 significant digits; 0 at or below ``floor`` (round-off of the table's
    largest entry)."""
    return "0" if abs(value) <= floor else f"{value:.4g}"


def vector(values: Any, scale: float, digits: int = 3) -> str:
    """A 3-vector times ``scale``, as ``(x, y, z)`` without negative zeros."""
    return "(" + ", ".join(number(float(v) * scale, digits) for v in values) + ")"


def outputs_table(equilibrium: Any) -> list[str]:
    """The world displacement of every output [um, urad], with exact - linear and the estimate."""
    measured = (equilibrium.difference or {}).get("outputs", {})
    bounds = (equilibrium.difference_bound or {}).get("outputs", {})
    header = ["output", "|translation| [um]", "translation (world) [um]", "|rotation| [urad]"]
    if measured:
        header += ["exact - linear [um]", "[urad]"]
    if bounds:
        header += ["estimate [um]"]
    rows = []
    for name, (t, r) in equilibrium.outputs.items():
        row = [
            name,
            number(float(np.linalg.norm(t)) * UM, 3),
            vector(t, UM),
            number(float(np.linalg.norm(r)) * URAD, 3),
        ]
        if measured:
            dt, dr = measured.get(name, (np.full(3, np.nan), np.full(3, np.nan)))
            row += [f"{np.linalg.norm(dt) * UM:.4g}", f"{np.linalg.norm(dr) * URAD:.4g}"]
        if bounds:
            bound = bounds.get(name, (np.nan, np.nan))[0]
            row += ["n/a" if not np.isfinite(bound) else f"{bound * UM:.4g}"]
        rows.append(row)
    return [
        f"outputs: world displacement, world axes ({equilibrium.formulation} model)",
        *columns(header, rows),
    ]


def contributors_table(equilibrium: Any) -> list[str]:
    """Per output frame of a mechanism without loops: each joint's share of its translation [um]
    (:meth:`~.result.Equilibrium.contributions`), largest first, with its part of the total."""
    if equilibrium.mechanism.loop_joints:  # a loop's passive joints follow: no own share
        return []
    lines: list[str] = []
    for name, (translation, _) in equilibrium.outputs.items():
        if "@" in name:  # a loaded point, not a frame
            continue
        shares = equilibrium.contributions(name)
        total = float(np.linalg.norm(translation))
        if not shares or total == 0.0:
            continue
        rows = [
            [joint, f"{np.linalg.norm(t) * UM:.4g}", vector(t, UM),
             f"{np.dot(t, translation) / total**2 * 100:.1f}"]
            for joint, (t, _) in shares.items()
        ]  # fmt: skip
        moved_by = "play and springs" if equilibrium.deflections else "play"
        lines += [
            f"what moves {name}: each joint's {moved_by}, world axes (shares sum to its "
            "translation)",
            *columns(["joint", "|share| [um]", "share (world) [um]", "along it [%]"], rows),
        ]
    return lines


def bearing_loads_table(equilibrium: Any) -> list[str]:
    """Per joint: radial and axial force [N], transverse moment and drive torque [N m] (the drive
    force [N] of a driven prismatic joint; with backlash, what its stop holds), in the joint's
    clearance frame."""
    reactions = {name: equilibrium.reaction(name, frame="joint") for name in equilibrium.torsors}
    largest = max((float(np.abs(r.wrench).max()) for r in reactions.values()), default=0.0)
    floor = 1e-9 * largest  # what the recovery of the reactions leaves at round-off
    rows = []
    stops = {name: np.zeros(6) for name in reactions}  # drive backlash stops: the drive's load
    for c in equilibrium.contacts:
        if c.point == "backlash":
            stops[c.joint] += np.concatenate(
                [c.force, np.zeros(3) if c.moment is None else c.moment]
            )
    for name, reaction in reactions.items():
        stop = stops[name]
        force, moment, drive = reaction.force - stop[:3], reaction.moment, reaction.drive + stop
        prismatic = getattr(equilibrium.mechanism.joints[name], "motion_component", None) == 0
        drive_text = ""
        if np.any(drive):
            drive_text = (
                f"{significant(drive[0], floor)} N"
                if prismatic
                else f"{significant(drive[3], floor)} N m"
            )
        rows.append(
            [
                name,
                significant(float(np.hypot(force[1], force[2])), floor),
                significant(float(force[0]), floor),
                significant(float(np.hypot(moment[1], moment[2])), floor),
                drive_text,
            ]
        )
    header = ["joint", "radial [N]", "axial [N]", "transverse moment [N m]", "drive"]
    lines = [
        "bearing loads: the parent part on the child through each joint, clearance frame "
        "(x = joint axis), moments about the joint centre",
        *columns(header, rows),
    ]
    mechanism = equilibrium.mechanism
    chains = chain_multipliers(getattr(mechanism, "couplings", ()), mechanism.joints)
    if chains:  # a leader's motor also carries its followers' torques
        motors = equilibrium.motor_torques()
        for motor, torque in motors.items():
            moved = [
                f"{factor:g} x {name}'s" for name, (root, factor) in chains.items() if root == motor
            ]
            if moved:
                unit = (
                    "N"
                    if getattr(mechanism.joints[motor], "motion_component", None) == 0
                    else "N m"
                )
                lines.append(
                    f"motor of {motor}: {significant(torque, floor)} {unit} (its own joint's "
                    f"drive plus {', '.join(moved)} through the couplings)"
                )
    return lines


def contacts_table(equilibrium: Any) -> list[str]:
    """Every contact point: gap [um], force [N] and its direction (clearance frame), where it acts
    in the world [mm] (nominal pose for the linear model, solved pose for the exact one)."""
    rows, stops = [], []
    for c in equilibrium.contacts:
        if c.moment is not None:  # a drive's backlash stop: a moment about the axis
            stops.append(c)
            continue
        magnitude = c.force_magnitude
        direction = c.force / magnitude if magnitude > 0 else c.force
        where = "" if c.world_position is None else vector(c.world_position, MM, 3)
        rows.append(
            [
                c.label,
                number(c.gap * UM, 4),
                f"{magnitude:.5g}",
                vector(direction, 1.0),
                where,
                "contact" if c.active else "",
            ]
        )
    header = ["contact", "gap [um]", "force [N]", "direction", "at (world) [mm]", ""]
    lines = [
        "contacts: force of the parent on the child, joint's clearance frame",
        *columns(header, rows),
    ]
    if stops:
        clearances = {c.joint: equilibrium.mechanism.joints[c.joint].clearance for c in stops}
        stop_rows = [
            [
                c.label,
                number(clearances[c.joint].backlash / 2 * URAD, 1),
                number(c.gap / c.clearance * clearances[c.joint].backlash / 2 * URAD, 1),
                f"{c.moment[0]:.5g}",
                "at its stop" if c.active else "",
            ]
            for c in stops
        ]
        header = ["drive", "b/2 [urad]", "left [urad]", "moment [N m]", ""]
        lines += [
            "drive backlash: the stop's moment on the child about the joint axis",
            *columns(header, stop_rows),
        ]
    return lines


def torsors_table(equilibrium: Any) -> list[str]:
    """Joint torsors in their clearance frames: u, v, w [um], alpha, beta, gamma [urad]."""
    rows = [
        [name, *(number(v * UM) for v in t[:3]), *(number(v * URAD) for v in t[3:])]
        for name, t in equilibrium.torsors.items()
    ]
    header = ["joint", "u [um]", "v [um]", "w [um]", "alpha [urad]", "beta [urad]", "gamma [urad]"]
    lines = ["joint torsors: child relative to parent, clearance frame", *columns(header, rows)]
    if equilibrium.deflections:
        springs = [
            [name, *(number(v * UM) for v in d[:3]), *(number(v * URAD) for v in d[3:])]
            for name, d in equilibrium.deflections.items()
        ]
        lines += [
            "of which springs (joint stiffness; the rest is play), clearance frame",
            *columns(header, springs),
        ]
    return lines


def report(equilibrium: Any) -> str:
    """The whole text report of ``equilibrium`` (module docstring)."""
    r = equilibrium.residuals
    lines = [
        f"equilibrium ({equilibrium.formulation} model): {equilibrium.status}, ok={equilibrium.ok}, "
        f"energy {equilibrium.energy:.6g} J",
        "",
        *outputs_table(equilibrium),
        *contributors_table(equilibrium),
    ]
    if equilibrium.difference:
        lines.append(
            f"exact - linear at the outputs: {equilibrium.difference['translation_m'] * UM:.4g} um, "
            f"{equilibrium.difference['rotation_rad'] * URAD:.4g} urad"
        )
    if equilibrium.loads is not None:
        try:
            lines += ["", *bearing_loads_table(equilibrium)]
        except ClearancePinError as exc:  # reactions cannot be recovered: say why, keep the rest
            lines += ["", f"bearing loads: not available ({exc})"]
    lines += ["", *contacts_table(equilibrium), "", *torsors_table(equilibrium)]
    for name, (t, rot) in equilibrium.eccentricities.items():
        lines.append(
            f"eccentric (misaligned housing) {name}: offset {vector(t, UM)} um, tilt "
            f"{vector(rot, URAD)} urad; its torsor is measured from there"
        )
    free = list(dict.fromkeys(equilibrium.free_motions))  # each once, in order
    if free:
        lines.append("free (indeterminate, set to the minimum-norm point):")
        lines += [f"  {motion}" for motion in free]
    lines.append(
        f"solver: {equilibrium.method.value} ({equilibrium.solver_status}), "
        f"{equilibrium.iterations} iterations, "
        f"polished={equilibrium.polished}; KKT {r.get('stationarity', 0.0):.1e}, statics "
        f"{r.get('statics', 0.0):.1e}, max violation "
        f"{abs(r.get('max_violation_m', 0.0)) * UM:.1e} um; "
        f"build {equilibrium.build_time * 1e3:.2f} ms, solve {equilibrium.solve_time * 1e3:.2f} ms"
    )
    if equilibrium.note:
        lines.append(equilibrium.note)
    return "\n".join(lines)


__all__ = [
    "bearing_loads_table",
    "columns",
    "contacts_table",
    "number",
    "outputs_table",
    "report",
    "torsors_table",
    "vector",
]

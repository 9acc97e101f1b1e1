"""What ``clearance-pin ... --json`` prints: versioned documents, one JSON Schema per kind.

Every document carries ``"schema": "clearance_pin/<kind>/<version>"``; its schema is shipped in
the package (``clearance_pin/schemas/<kind>-<version>.json``, :func:`schema`). Quantities carry an
SI unit suffix (``_m``, ``_rad``, ``_N``, ``_N_m``, ``_J``, ``_s``); every vector names its frame.
Kinds: ``solve`` (an equilibrium, its linear answer, the check), ``envelope`` (the clearance
envelope of each output), ``tolerance`` (a tolerance sweep, :mod:`.tolerance.command`),
``accuracy`` (an accuracy map's summary), ``identify`` (drives identified from measured
deflections, :mod:`.identification.command`), ``error`` (a failure: what went wrong and the exit
status). Version 1 replaces the unversioned documents of before.
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from typing import Any

import numpy as np

from .equilibrium.outputs import resolve_outputs

SOLVE_SCHEMA = "clearance_pin/solve/1"
ENVELOPE_SCHEMA = "clearance_pin/envelope/1"
TOLERANCE_SCHEMA = "clearance_pin/tolerance/1"
ACCURACY_SCHEMA = "clearance_pin/accuracy/1"
IDENTIFY_SCHEMA = "clearance_pin/identify/1"
ERROR_SCHEMA = "clearance_pin/error/1"
UNITS = {"translation": "m", "rotation": "rad"}


@cache
def schema(kind: str, version: int = 1) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of documents of ``kind`` (``"solve"``, ``"error"``)."""
    text = resources.files("clearance_pin.schemas").joinpath(f"{kind}-{version}.json").read_text()
    loaded: dict[str, Any] = json.loads(text)
    return loaded


def _vector(values: Any) -> list[float]:
    return [float(v) for v in np.asarray(values, dtype=float).ravel()]


def equilibrium_document(equilibrium: Any) -> dict[str, Any]:
    """One equilibrium: outputs, joint torsors, bearing loads, reactions, contacts, residuals."""
    mechanism = equilibrium.mechanism
    outputs = {}
    points = equilibrium.output_points or resolve_outputs(mechanism, equilibrium.loads or ())
    oMi = equilibrium.configuration.oMi
    for point in points:
        translation, rotation = equilibrium.outputs[point.name]
        loaded = "@" in point.name  # a load's point (named link@[x y z] in the text table)
        link = point.name.split("@", 1)[0]
        outputs[point.name] = {  # the name the table and Equilibrium.outputs use
            "kind": "load point" if loaded else "frame",
            "link": link,
            "nominal_world_position_m": _vector((oMi[point.body] * point.placement).translation),
            "translation_m": _vector(translation),
            "rotation_rad": _vector(rotation),
            "frame": "world",
        }
    torsors = {
        name: {
            "translation_m": _vector(t[:3]),
            "rotation_rad": _vector(t[3:]),
            "frame": f"clearance frame of {name}",
        }
        for name, t in equilibrium.torsors.items()
    }
    for name, deflection in (equilibrium.deflections or {}).items():  # a joint's springs' part
        torsors[name]["spring_translation_m"] = _vector(deflection[:3])
        torsors[name]["spring_rotation_rad"] = _vector(deflection[3:])
    bearing, reactions = {}, {}
    for name in equilibrium.torsors:
        local = equilibrium.reaction(name, frame="joint")
        world = equilibrium.reaction(name, frame="world")
        stop = np.zeros(6)
        for c in equilibrium.contacts:
            if c.joint == name and c.point == "backlash":
                stop += np.concatenate([c.force, np.zeros(3) if c.moment is None else c.moment])
        force, moment = local.force - stop[:3], local.moment
        drive = local.drive + stop
        slide = getattr(mechanism.joints[name], "motion_component", None) == 0
        bearing[name] = {
            "radial_N": float(np.hypot(force[1], force[2])),
            "axial_N": float(force[0]),
            "transverse_moment_N_m": float(np.hypot(moment[1], moment[2])),
            **({"drive_N": float(drive[0])} if slide else {"drive_N_m": float(drive[3])}),
            "frame": f"clearance frame of {name}",
        }
        reactions[name] = {
            "force_N": _vector(world.force),
            "moment_N_m": _vector(world.moment),
            "frame": "world",
            "moment_about": "world origin",
            "statics_residual": float(world.residual),
        }
    contacts = []
    for c in equilibrium.contacts:
        entry = {
            "joint": c.joint,
            "point": c.point,
            "active": bool(c.active),
            "gap_m": float(c.gap),
            "clearance_m": float(c.clearance),
            "force_N": _vector(c.force),
            "position_m": _vector(c.position),
            "world_position_m": _vector(c.world_position),
            "frame": f"clearance frame of {c.joint} (parent side)",
        }
        if c.moment is not None:
            entry["moment_N_m"] = _vector(c.moment)
        contacts.append(entry)
    difference = equilibrium.difference
    return {
        "formulation": equilibrium.formulation,
        "status": equilibrium.status,
        "ok": bool(equilibrium.ok),
        "method": equilibrium.method.value,
        "solver_status": equilibrium.solver_status,
        "iterations": int(equilibrium.iterations),
        "polished": bool(equilibrium.polished),
        "energy_J": float(equilibrium.energy),
        "build_time_s": float(equilibrium.build_time),
        "solve_time_s": float(equilibrium.solve_time),
        "outputs": outputs,
        "torsors": torsors,
        "bearing_loads": bearing,
        "reactions": reactions,
        "contacts": contacts,
        "residuals": {k: float(v) for k, v in equilibrium.residuals.to_dict().items()},
        "free_motions": list(equilibrium.free_motions),
        "difference_exact_linear": None
        if difference is None
        else {
            "largest_translation_m": float(difference["translation_m"]),
            "largest_rotation_rad": float(difference["rotation_rad"]),
        },
        "note": equilibrium.note,
    }


def solve_document(model: str, equilibrium: Any, check: Any = None) -> dict[str, Any]:
    """The ``solve`` document (:data:`SOLVE_SCHEMA`): the equilibrium, the linear answer an
    exact one started from, the coal check of the exact pose and the linear pose's departure
    (``check.departure``)."""
    document: dict[str, Any] = {
        "schema": SOLVE_SCHEMA,
        "model": model,
        "equilibrium": equilibrium_document(equilibrium),
    }
    if equilibrium.linear is not None:
        document["linear"] = equilibrium_document(equilibrium.linear)
    if check is not None:
        document["check"] = check.to_dict()
    if check is not None and check.departure is not None:
        document["linear_departure"] = check.departure.to_dict()
    return document


def envelope_document(model: str, envelopes: Any) -> dict[str, Any]:
    """The ``envelope`` document (:data:`ENVELOPE_SCHEMA`): per output, per kind (translation
    [m], rotation [rad]) the certified largest deviation (its bounds, the state and load direction
    that reach it) and the ranges along the world's and the output frame's axes (null: unbounded
    along a free direction)."""
    return {
        "schema": ENVELOPE_SCHEMA,
        "model": model,
        "envelopes": [_envelope(envelope) for envelope in envelopes],
    }


def _envelope(envelope: Any) -> dict[str, Any]:
    output = envelope.output
    kinds = {}
    for kind, part in envelope.kinds.items():
        unit = UNITS[kind]
        extreme = part.maximum
        entry: dict[str, Any] = {
            "span": [_vector(v) for v in part.basis.T],
            "free_directions": [_vector(v) for v in part.free.T],
            "unbounded": bool(part.free.shape[1]),
            f"largest_lower_{unit}": float(extreme.lower),
            f"largest_upper_{unit}": float(extreme.upper),
            "relative_gap": float(extreme.gap),
            "certified": bool(extreme.certified),
            "method": extreme.method,
            "directions": int(extreme.directions),
            f"deviation_{unit}": _vector(extreme.deviation),
            "load_direction": _vector(extreme.direction),
            "frame": "world",
            "contacts": list(extreme.contacts),
            f"world_ranges_{unit}": _ranges(part.world),
            f"output_frame_ranges_{unit}": _ranges(part.frame),
            "contributors": [
                {"joint": joint, f"share_{unit}": _vector(share)}
                for joint, share in envelope.contributors(kind).items()
            ],
        }
        if envelope.exact is not None and kind in envelope.exact:
            exact = envelope.exact[kind]
            entry["exact"] = {
                f"largest_{unit}": float(exact.largest),
                f"linear_largest_{unit}": float(exact.linear_largest),
                f"deviation_{unit}": _vector(exact.deviation),
                "load_direction": _vector(exact.direction),
                f"world_ranges_{unit}": _ranges(exact.world),
                f"output_frame_ranges_{unit}": _ranges(exact.frame),
                "certified": False,
            }
        kinds[kind] = entry
    return {
        "mechanism": envelope.mechanism_name,
        "output": {
            "name": output.name,
            "link": output.link,
            "point_m": _vector(output.point),
            "point_frame": f"link {output.link}",
            "nominal_world_position_m": _vector(output.position),
        },
        "q": _vector(envelope.q),
        "relative_tolerance": float(envelope.tol),
        "kinds": kinds,
        "timings_s": {key: float(value) for key, value in envelope.timings.items()},
    }


def _ranges(ranges: Any) -> dict[str, list[float | None]]:
    """Axis name -> [min, max] (None for an unbounded side: JSON has no infinity)."""
    return {
        axis: [float(v) if np.isfinite(v) else None for v in row]
        for axis, row in zip("xyz", np.asarray(ranges, dtype=float))
    }


def error_document(
    command: str, model: str | None, error: str, message: str, status: int
) -> dict[str, Any]:
    """The ``error`` document (:data:`ERROR_SCHEMA`) a ``--json`` command prints on failure."""
    return {
        "schema": ERROR_SCHEMA,
        "command": command,
        "model": model,
        "error": error,
        "message": message,
        "exit_status": status,
    }


__all__ = [
    "ACCURACY_SCHEMA",
    "ENVELOPE_SCHEMA",
    "ERROR_SCHEMA",
    "IDENTIFY_SCHEMA",
    "SOLVE_SCHEMA",
    "TOLERANCE_SCHEMA",
    "envelope_document",
    "error_document",
    "schema",
    "solve_document",
]

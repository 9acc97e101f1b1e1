r"""The memory a mechanism needs to be solved, estimated from its size before anything is allocated.

A mechanism keeps one ``pin.Data`` per thread that solves it
(:class:`~clearance_pin.equilibrium.cache.SolveCache`), unless it is a tree whose data would
exceed :data:`DATA_KEPT_UP_TO`: that one is placed without
(:mod:`clearance_pin.kinematics.placements`). Pinocchio 4.1's data holds second-order derivative
tensors of size :math:`n_v^3`: measured (resident memory of one ``createData()`` of chains of
revolute joints, n_v = 50 to 250) it takes about :math:`64\, n_v^3 + 1000\, n_v^2` bytes plus
4 MB, 1.7 GB at 300 joints, 8 GB at 500. The prepared geometry of a solve adds dense maps of
:math:`8 \cdot 6 n_j \cdot 6 n_j` bytes each, about :data:`MAPS_PER_SOLVE` of them at the peak
of a solve (measured at 300 and 500 joints: 0.38 and 1.5 GB).
A mechanism whose estimate exceeds the memory available is refused with a
:class:`~clearance_pin.errors.ModelError` naming the size, instead of being killed by the system
when the data is allocated.
"""

from __future__ import annotations

import os

import pinocchio as pin

from ..errors import ModelError

DATA_CUBIC = 64.0  # [bytes per nv^3] of one pin.Data (Pinocchio 4.1, measured)
DATA_QUADRATIC = 1000.0  # [bytes per nv^2]
DATA_BASE = 4e6  # [bytes]
MAPS_PER_SOLVE = 20  # (6 joints, 6 joints) float arrays at the peak of a solve (measured)
ALWAYS_FITS = 64e6  # [bytes]: an estimate below is not compared with the memory available
DATA_KEPT_UP_TO = 64e6  # [bytes]: a tree whose pin.Data would be larger is placed without one


def data_bytes(nv: int) -> float:
    """Estimated size of one ``pin.Data`` [bytes] of a model with ``nv`` velocity coordinates."""
    return DATA_CUBIC * nv**3 + DATA_QUADRATIC * nv**2 + DATA_BASE


def solve_bytes(model: pin.Model, with_data: bool = True) -> float:
    """Estimated memory [bytes] a mechanism on ``model`` needs to be solved from one thread:
    its ``pin.Data`` (``with_data``) and the maps of one prepared geometry."""
    joints = int(model.njoints)
    maps = MAPS_PER_SOLVE * 8.0 * (6 * joints) * (6 * joints)
    return (data_bytes(int(model.nv)) if with_data else 0.0) + maps


def available_bytes() -> int | None:
    """Memory [bytes] the process may still use: the system's available memory
    (``MemAvailable`` of /proc/meminfo), less when a cgroup limit leaves less; None where
    neither can be read (no refusal then)."""
    found: list[int] = []
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
                    break
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max", encoding="ascii") as limit_file:
            limit = limit_file.read().strip()
        with open("/sys/fs/cgroup/memory.current", encoding="ascii") as current_file:
            current = int(current_file.read().strip())
        if limit != "max":
            found.append(max(int(limit) - current, 0))
    except (OSError, ValueError):
        pass
    if not found and hasattr(os, "sysconf"):
        try:
            found.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (OSError, ValueError):
            pass
    return min(found) if found else None


def check_fits(
    model: pin.Model, source: str, available: float | None = None, with_data: bool = True
) -> None:
    """Refuse a model whose estimated memory (:func:`solve_bytes`) exceeds ``available`` [bytes]
    (default: :func:`available_bytes`); ``with_data``: a ``pin.Data`` counted (a long tree is
    placed without one: :mod:`clearance_pin.kinematics.placements`).

    Raises:
        ModelError: naming the number of joints and coordinates, the estimate and what is
            available.
    """
    needed = solve_bytes(model, with_data)
    if available is None and needed < ALWAYS_FITS:
        return  # not worth reading the system's figures for every mechanism built
    if available is None:
        available = available_bytes()
    if available is not None and needed > available:
        part = (
            f"Pinocchio's data grows as the cube of the coordinates: about "
            f"{data_bytes(model.nv) / 1e9:.3g} GB"
            if with_data
            else "the maps of a solve grow as the square of the joints"
        )
        raise ModelError(
            source,
            "<robot>",
            f"{model.njoints - 1} joints ({model.nv} coordinates) need about "
            f"{needed / 1e9:.3g} GB to solve ({part}), more than the {available / 1e9:.3g} GB "
            "available: split the mechanism, or make the joints that do not matter fixed",
        )


__all__ = [
    "ALWAYS_FITS",
    "DATA_KEPT_UP_TO",
    "available_bytes",
    "check_fits",
    "data_bytes",
    "solve_bytes",
]

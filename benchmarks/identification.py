"""Time of ``Mechanism.identify`` (issue 35): the UR5 of example-robot-data, its 6 drives' backlash
and stiffness (12 parameters) from 200 random poses x 3 loads (the rated 5 kg hung, and pulled
along +x and -x), measurements made from Pinocchio's Jacobians (tests/identification_synthetic.py),
10 um of noise. Run it as a fresh process:

    python benchmarks/identification.py [--poses 200] [--repeats 5] [--json FILE]

It prints the time of the first identification in the process (the robot loaded, nothing
solved before), the median of the next ``--repeats`` (each on a freshly loaded robot: nothing
kept between them), and the time from the interpreter's start to the end of the first one.
"""

from __future__ import annotations

import time

STARTED = time.perf_counter()

import argparse  # (after the clock starts: the imports are in the time)
import json
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

import arms
import identification_synthetic as synthetic

import clearance_pin
from clearance_pin.identification import Measurements

JOINTS = arms.VENDOR["ur5"][1]  # the nominal pose [rad], as the arm benchmarks'
BACKLASH = np.array([5e-4, 4e-4, 6e-4, 8e-4, 7e-4, 9e-4])  # [rad], the "true" drives
STIFFNESS = np.array([3.0e4, 2.5e4, 1.5e4, 6e3, 5e3, 4e3])  # [N m/rad]
POINT = ("tool0", [0.2, 0.0, 0.1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    urdf = arms.vendor_file("ur_description/urdf/ur5_robot.urdf")
    if urdf is None:
        raise SystemExit("example-robot-data is not installed (pip install -e '.[test]')")
    folder = Path(tempfile.mkdtemp())
    sheet = folder / "ur5_datasheet.toml"
    lines = ["[defaults.revolute]", "driven = true", "backlash = 3e-4", "drive_stiffness = 1e4"]
    for name, q in JOINTS.items():
        lines += [f"[joints.{name}]", f"q = {q!r}"]
    sheet.write_text("\n".join(lines) + "\n")
    robot = clearance_pin.load(str(urdf), clearances=sheet)
    model = robot.model
    rng = np.random.default_rng(0)
    low, high = model.lowerPositionLimit, model.upperPositionLimit
    poses = rng.uniform(low, high, (args.poses, model.nq))
    f = 5.0 * synthetic.G
    forces = np.array([[0.0, 0.0, -f], [f, 0.0, 0.0], [-f, 0.0, 0.0]])
    rows = synthetic.measurements(
        model, POINT[0], POINT[1], list(JOINTS), BACKLASH, STIFFNESS, poses, forces,
        noise=10e-6, seed=1,
    )  # fmt: skip
    data = Measurements.from_arrays(rows["pose"], rows["q"], rows["force"], rows["position"])
    began = time.perf_counter()
    first = robot.identify(data, point=POINT)
    first_time = time.perf_counter() - began
    since_start = time.perf_counter() - STARTED
    times = []
    for _ in range(args.repeats):
        fresh = clearance_pin.load(str(urdf), clearances=sheet)
        began = time.perf_counter()
        fresh.identify(data, point=POINT)
        times.append(time.perf_counter() - began)
    worst = max(
        abs(first.parameter(n, kind).value / truth - 1)
        for kind, values in (("backlash", BACKLASH), ("drive_stiffness", STIFFNESS))
        for n, truth in zip(JOINTS, values)
    )
    report = {
        "parameters": len(first.parameters),
        "poses": args.poses,
        "loads_per_pose": len(forces),
        "status": first.status,
        "first_identify_s": first_time,
        "median_identify_s": statistics.median(times) if times else None,
        "process_start_to_first_identified_s": since_start,
        "largest_relative_error": worst,
    }
    print(
        f"UR5, {report['parameters']} parameters from {args.poses} poses x {len(forces)} loads "
        f"(10 um noise): {first.status}, largest relative error {worst:.2%}\n"
        f"  first identify in the process {first_time:.3f} s; median of {len(times)} more "
        f"{report['median_identify_s']:.3f} s; interpreter start to first result "
        f"{since_start:.2f} s"
    )
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()

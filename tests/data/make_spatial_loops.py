"""Write the spatial-loop models of tests/test_spatial_loops.py (spatial_rssr.urdf, spatial_delta.urdf,
spatial_stewart.urdf).

Run from the repository root: ``python tests/data/make_spatial_loops.py``. The design numbers
(SI: m, rad) are the constants below; tests/test_spatial_loops.py repeats them for its own numpy
geometry. Every model is written at a nominal configuration solved here from its design (plain
numpy: a circle-sphere intersection for the RSSR, an inverse kinematics for the Delta and the
Stewart platform), so the file pose is closed to round-off and the loader's closure only polishes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

# -- RSSR: crank about z through O, rocker about x through D, coupler between the two balls ------
RSSR = {"crank": 0.03, "coupler": 0.13, "rocker": 0.07, "pivot": (0.08, 0.05, 0.06)}
# -- Delta: three arms (shoulders tangential at 120 deg), parallelogram rods to a platform -------
DELTA = {
    "base_radius": 0.10,
    "arm": 0.10,
    "rod": 0.22,
    "platform_radius": 0.04,
    "rod_spacing": 0.05,
    "height": 0.18,  # platform centre below the shoulders at the nominal configuration
}
# -- Stewart platform: 6 legs from a base circle to a platform circle (6-6 arrangement) ---------
STEWART = {
    "base_radius": 0.15,
    "platform_radius": 0.08,
    "base_angles_deg": (-10.0, 10.0, 110.0, 130.0, 230.0, 250.0),
    "platform_angles_deg": (-50.0, 50.0, 70.0, 170.0, 190.0, 290.0),
    "height": 0.20,
}


def num(x: float) -> str:
    return repr(float(x))


def vec(v) -> str:
    return " ".join(num(x) for x in v)


def rpy(rotation: np.ndarray) -> str:
    """URDF roll-pitch-yaw of a rotation matrix (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    pitch = np.arcsin(-np.clip(rotation[2, 0], -1.0, 1.0))
    roll = np.arctan2(rotation[2, 1], rotation[2, 2])
    yaw = np.arctan2(rotation[1, 0], rotation[0, 0])
    return vec((roll, pitch, yaw))


def rot_x(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def frame_z_along(direction: np.ndarray) -> np.ndarray:
    """A rotation whose z column is ``direction`` (x in the horizontal plane)."""
    z = direction / np.linalg.norm(direction)
    x = np.cross([0.0, 0.0, 1.0], z)
    x = x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-9 else np.array([1.0, 0.0, 0.0])
    return np.column_stack([x, np.cross(z, x), z])


INERTIAL = (
    '<inertial><mass value="{m}"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" '
    'iyz="0"/></inertial>'
)


def link(name: str, mass: float | None = None) -> str:
    if mass is None:
        return f'  <link name="{name}"/>'
    return f'  <link name="{name}">{INERTIAL.format(m=mass)}</link>'


def joint(name, kind, parent, child, xyz=(0, 0, 0), rotation=None, axis=None, limit=None):
    origin = f'<origin xyz="{vec(xyz)}"' + (
        f' rpy="{rpy(rotation)}"' if rotation is not None else ""
    )
    parts = [f'<parent link="{parent}"/><child link="{child}"/>{origin}/>']
    if axis is not None:
        parts.append(f'<axis xyz="{vec(axis)}"/>')
    if limit is not None:
        parts.append(f'<limit lower="{limit[0]}" upper="{limit[1]}" effort="1000" velocity="10"/>')
    return f'  <joint name="{name}" type="{kind}">' + "".join(parts) + "</joint>"


# -- RSSR ------------------------------------------------------------------------------------
def rssr_rocker_angle(theta: float, design=RSSR, branch: int = +1) -> float:
    """Rocker angle psi closing the RSSR at crank angle theta: |A(theta) - B(psi)| = coupler.

    A = a (cos t, sin t, 0); B = D + c (0, cos psi, sin psi): the condition is
    k1 cos psi + k2 sin psi = k3, solved as psi = atan2(k2, k1) + branch * acos(k3 / |k|)."""
    a, b, c = design["crank"], design["coupler"], design["rocker"]
    d = np.asarray(design["pivot"])
    p = d - a * np.array([np.cos(theta), np.sin(theta), 0.0])  # D - A
    k1, k2 = 2.0 * c * p[1], 2.0 * c * p[2]
    k3 = b * b - p @ p - c * c
    return float(np.arctan2(k2, k1) + branch * np.arccos(k3 / np.hypot(k1, k2)))


def write_rssr() -> str:
    a, b, c = RSSR["crank"], RSSR["coupler"], RSSR["rocker"]
    d = np.asarray(RSSR["pivot"])
    psi = rssr_rocker_angle(0.0)
    ball_a = np.array([a, 0.0, 0.0])
    ball_b = d + c * np.array([0.0, np.cos(psi), np.sin(psi)])
    assert abs(np.linalg.norm(ball_b - ball_a) - b) < 1e-15
    lines = [
        '<?xml version="1.0"?>',
        "<!-- RSSR spatial four-bar (tests/data/README.md): crank 30 mm about z through O, driven;",
        "     coupler 130 mm between two balls; rocker 70 mm about x through D = (80, 50, 60) mm.",
        "     The coupler hangs from the crank on a floating joint carrying a spherical clearance;",
        "     ball_B closes the loop. Written by tests/data/make_spatial_loops.py. -->",
        '<robot name="rssr">',
        link("ground"),
        link("crank", 0.2),
        link("coupler", 0.3),
        link("rocker", 0.25),
        link("coupler_B"),
        link("rocker_B"),
        joint("crank_pivot", "revolute", "ground", "crank", axis=(0, 0, 1), limit=(-20, 20)),
        joint("ball_A", "floating", "crank", "coupler", xyz=ball_a),
        joint("coupler_B_mount", "fixed", "coupler", "coupler_B", xyz=ball_b - ball_a),
        joint(
            "rocker_pivot", "revolute", "ground", "rocker", xyz=d, axis=(1, 0, 0), limit=(-20, 20)
        ),
        joint("rocker_B_mount", "fixed", "rocker", "rocker_B", xyz=(0.0, c, 0.0)),
        "  <clearance_pin>",
        '    <joint name="crank_pivot" type="revolute" radial_clearance="2e-05" length="0.02" '
        'axial_clearance="1e-05" driven="true" q="0.0"/>',
        '    <joint name="ball_A" type="spherical" radial_clearance="2.5e-05"/>',
        '    <joint name="rocker_pivot" type="revolute" radial_clearance="2e-05" length="0.02" '
        f'axial_clearance="1e-05" q="{num(psi)}"/>',
        '    <loop_joint name="ball_B" type="spherical" frame_a="rocker_B" frame_b="coupler_B" '
        'radial_clearance="2.5e-05"/>',
        '    <torque link="rocker" value="-1.5 0 0"/>',
        # toleranced lengths: crank a, coupler b (along the coupler), rocker c, pivot x position
        '    <dimension name="a" joint="ball_A" direction="1 0 0" tolerance="1e-4"/>',
        f'    <dimension name="b" joint="coupler_B_mount" direction="{vec(ball_b - ball_a)}" '
        'tolerance="1e-4"/>',
        '    <dimension name="c" joint="rocker_B_mount" direction="0 1 0" tolerance="1e-4"/>',
        '    <dimension name="dx" joint="rocker_pivot" direction="1 0 0" tolerance="2e-4"/>',
        f'    <force link="rocker" point="0 {num(c / 2)} 0" value="0 0 -20"/>',
        "  </clearance_pin>",
        "</robot>",
    ]
    return "\n".join(lines) + "\n"


# -- Delta -------------------------------------------------------------------------------------
def delta_frames(design=DELTA):
    """Per arm i: shoulder position P_i, radial unit r_i, tangent unit t_i (the shoulder axis)."""
    out = []
    for k in range(3):
        phi = 2.0 * np.pi * k / 3.0
        r = np.array([np.cos(phi), np.sin(phi), 0.0])
        t = np.array([-np.sin(phi), np.cos(phi), 0.0])
        out.append((design["base_radius"] * r, r, t, phi))
    return out


def delta_arm_angles(platform: np.ndarray, design=DELTA) -> list[float]:
    """Inverse kinematics: shoulder angles theta_i (rotation about t_i, theta > 0 down) that put
    the platform centre at ``platform`` (platform parallel to the base).

    Elbow E = P + L (cos t r - sin t z); both rods of arm i are parallel to E - Q, Q = p + R_p r,
    and have the rod length: |E - Q|^2 = rod^2, i.e. k1 cos t + k2 sin t = k3 with e = P - Q
    (elbow-out branch)."""
    angles = []
    for p_i, r, _, _ in delta_frames(design):
        e = p_i - (platform + design["platform_radius"] * r)
        arm, rod = design["arm"], design["rod"]
        k1, k2 = 2.0 * arm * (e @ r), -2.0 * arm * e[2]
        k3 = rod * rod - e @ e - arm * arm
        angles.append(float(np.arctan2(k2, k1) + np.arccos(k3 / np.hypot(k1, k2))))
    return angles


def write_delta() -> str:
    arm, w = DELTA["arm"], DELTA["rod_spacing"]
    centre = np.array([0.0, 0.0, -DELTA["height"]])
    angles = delta_arm_angles(centre)
    lines = [
        '<?xml version="1.0"?>',
        "<!-- Delta-like 3-R(SS)2 platform (tests/data/README.md): three driven shoulders 120 deg",
        "     apart on a 100 mm circle, arms 100 mm, two 220 mm rods per arm (a parallelogram, 50 mm",
        "     wide) with a ball at each end, platform radius 40 mm, platform 180 mm below the base.",
        "     The platform hangs from rod_0a on a floating joint carrying a spherical clearance; five",
        "     ball loop joints close the loops. Written by tests/data/make_spatial_loops.py. -->",
        '<robot name="delta_3rss">',
        link("base"),
        link("platform", 0.5),
        link("tool"),
    ]
    joints, block = [], []
    first_end, rod_1a = None, None
    for k, ((p_i, r, t, phi), theta) in enumerate(zip(delta_frames(), angles)):
        yaw = rot_z(phi)  # shoulder frame: x radial, y tangential (the axis), z up
        arm_rotation = yaw @ rot_y(theta)
        elbow = p_i + arm_rotation @ np.array([arm, 0.0, 0.0])
        lines.append(link(f"arm_{k}", 0.1))
        joints.append(
            joint(
                f"shoulder_{k}",
                "revolute",
                "base",
                f"arm_{k}",
                xyz=p_i,
                rotation=yaw,
                axis=(0, 1, 0),
                limit=(-20, 20),
            )
        )
        block.append(
            f'    <joint name="shoulder_{k}" type="revolute" radial_clearance="1.5e-05" '
            f'length="0.02" axial_clearance="1e-05" driven="true" q="{num(theta)}"/>'
        )
        q_i = centre + DELTA["platform_radius"] * r
        for side, sign in (("a", 1.0), ("b", -1.0)):
            top = elbow + sign * 0.5 * w * t
            bottom = q_i + sign * 0.5 * w * t
            rod = f"rod_{k}{side}"
            lines += [link(rod, 0.02), link(f"{rod}_end")]
            joints.append(
                joint(
                    f"ball_{k}{side}_top",
                    "floating",
                    f"arm_{k}",
                    rod,
                    xyz=(arm, sign * 0.5 * w, 0.0),
                )
            )
            joints.append(
                joint(
                    f"{rod}_end_mount",
                    "fixed",
                    rod,
                    f"{rod}_end",
                    xyz=arm_rotation.T @ (bottom - top),
                )
            )
            block.append(
                f'    <joint name="ball_{k}{side}_top" type="spherical" radial_clearance="1.5e-05"/>'
            )
            if (k, side) == (1, "a"):
                rod_1a = arm_rotation.T @ (bottom - top)
            if first_end is None:
                first_end = (rod, bottom, arm_rotation)
                continue
            lines.append(link(f"platform_{k}{side}"))
            joints.append(
                joint(
                    f"platform_{k}{side}_mount",
                    "fixed",
                    "platform",
                    f"platform_{k}{side}",
                    xyz=bottom - first_end[1],
                )
            )
            block.append(
                f'    <loop_joint name="ball_{k}{side}_bottom" type="spherical" '
                f'frame_a="platform_{k}{side}" frame_b="{rod}_end" radial_clearance="1.5e-05"/>'
            )
    rod, bottom, rotation = first_end
    joints.append(
        joint("ball_0a_bottom", "floating", f"{rod}_end", "platform", rotation=rotation.T)
    )
    block.append('    <joint name="ball_0a_bottom" type="spherical" radial_clearance="1.5e-05"/>')
    joints.append(joint("tool_mount", "fixed", "platform", "tool", xyz=centre - bottom))
    block += [
        f'    <force link="platform" point="{vec(centre - bottom)}" value="8 -5 -40"/>',
        '    <torque link="platform" value="0.3 -0.2 0.5"/>',
        # toleranced: the arm length of arm 0 (both rod tops), the length of rod 1a
        '    <dimension name="arm0a" joint="ball_0a_top" direction="1 0 0" tolerance="1e-4"/>',
        '    <dimension name="arm0b" joint="ball_0b_top" direction="1 0 0" tolerance="1e-4"/>',
        f'    <dimension name="rod1a" joint="rod_1a_end_mount" direction="{vec(rod_1a)}" '
        'tolerance="1e-4"/>',
    ]
    lines += [*joints, "  <clearance_pin>", *block, "  </clearance_pin>", "</robot>"]
    return "\n".join(lines) + "\n"


# -- Stewart -----------------------------------------------------------------------------------
def stewart_points(design=STEWART):
    """Base points B_i (world) and platform points P_i (platform frame, centre at its origin)."""
    base = [
        design["base_radius"] * np.array([np.cos(np.radians(a)), np.sin(np.radians(a)), 0.0])
        for a in design["base_angles_deg"]
    ]
    top = [
        design["platform_radius"] * np.array([np.cos(np.radians(a)), np.sin(np.radians(a)), 0.0])
        for a in design["platform_angles_deg"]
    ]
    return base, top


def write_stewart() -> str:
    base, top = stewart_points()
    centre = np.array([0.0, 0.0, STEWART["height"]])
    tops = [centre + p for p in top]
    lines = [
        '<?xml version="1.0"?>',
        "<!-- 6-UPS Stewart platform (tests/data/README.md): base points on a 150 mm circle at",
        "     -10/10/110/130/230/250 deg, platform points on an 80 mm circle at -50/50/70/170/190/290",
        "     deg, platform 200 mm above the base. Each leg: a universal joint (two revolutes about",
        "     the leg frame's x then y), a driven prismatic joint along the leg, a ball at the top.",
        "     The platform hangs from leg 0 on a floating joint carrying a spherical clearance; five",
        "     ball loop joints close the loops. Written by tests/data/make_spatial_loops.py. -->",
        '<robot name="stewart_6ups">',
        link("base"),
        link("platform", 2.0),
        link("tool"),
    ]
    joints, block = [], []
    for k, (b, p) in enumerate(zip(base, tops)):
        leg = p - b
        length = float(np.linalg.norm(leg))
        rotation = frame_z_along(leg)
        lines += [link(f"cross_{k}"), link(f"lower_{k}", 0.3), link(f"upper_{k}", 0.2)]
        joints += [
            joint(
                f"u1_{k}",
                "revolute",
                "base",
                f"cross_{k}",
                xyz=b,
                rotation=rotation,
                axis=(1, 0, 0),
                limit=(-20, 20),
            ),
            joint(
                f"u2_{k}", "revolute", f"cross_{k}", f"lower_{k}", axis=(0, 1, 0), limit=(-20, 20)
            ),
            joint(
                f"leg_{k}",
                "prismatic",
                f"lower_{k}",
                f"upper_{k}",
                axis=(0, 0, 1),
                limit=(0.05, 0.6),
            ),
        ]
        for name in (f"u1_{k}", f"u2_{k}"):
            block.append(
                f'    <joint name="{name}" type="revolute" radial_clearance="1e-05" '
                'length="0.015" axial_clearance="1e-05"/>'
            )
        block.append(
            f'    <joint name="leg_{k}" type="prismatic" radial_clearance="1.5e-05" length="0.04" '
            f'width="0.02" height="0.02" driven="true" q="{num(length)}"/>'
        )
        if k == 0:
            joints.append(joint("ball_0", "floating", "upper_0", "platform", rotation=rotation.T))
            block.append('    <joint name="ball_0" type="spherical" radial_clearance="2e-05"/>')
            continue
        lines.append(link(f"platform_{k}"))
        joints.append(
            joint(f"platform_{k}_mount", "fixed", "platform", f"platform_{k}", xyz=p - tops[0])
        )
        block.append(
            f'    <loop_joint name="ball_{k}" type="spherical" frame_a="platform_{k}" '
            f'frame_b="upper_{k}" radial_clearance="2e-05"/>'
        )
    joints.append(joint("tool_mount", "fixed", "platform", "tool", xyz=centre - tops[0]))
    block += [
        f'    <force link="platform" point="{vec(centre - tops[0])}" value="10 -5 -100"/>',
        '    <torque link="platform" value="1 0.5 2"/>',
        # toleranced: the base point of leg 2 (x, y), the platform point of leg 4 (z)
        '    <dimension name="b2x" joint="u1_2" direction="1 0 0" tolerance="1e-4"/>',
        '    <dimension name="b2y" joint="u1_2" direction="0 1 0" tolerance="1e-4"/>',
        '    <dimension name="p4z" joint="platform_4_mount" direction="0 0 1" tolerance="1e-4"/>',
    ]
    lines += [*joints, "  <clearance_pin>", *block, "  </clearance_pin>", "</robot>"]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    for name, text in (
        ("spatial_rssr.urdf", write_rssr()),
        ("spatial_delta.urdf", write_delta()),
        ("spatial_stewart.urdf", write_stewart()),
    ):
        (HERE / name).write_text(text)
        print("wrote", HERE / name)

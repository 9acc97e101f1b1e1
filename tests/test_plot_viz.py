"""The interactive view (clearance_pin.plot.show_equilibrium, the viz extra), served headless:
a meshcat server on 127.0.0.1 is started, the settled pose is set, a WebSocket client (what the
browser page is) receives the scene's objects and transforms, and the server is stopped."""

from __future__ import annotations

import asyncio
import sys

import numpy as np
import pinocchio as pin
import pytest
from conftest import MODELS

import clearance_pin
from clearance_pin.plot import show_equilibrium, show_trajectory, skeleton
from clearance_pin.plot.style import nice_round
from clearance_pin.plot.viz import (
    compose_trs,
    decompose_trs,
    magnified_motion,
    part_matrix,
    split_affine,
)

BOXES = """<?xml version="1.0"?>
<robot name="boxes">
  <link name="ground"/>
  <link name="arm">
    <visual><origin xyz="0.1 0 0"/><geometry><box size="0.2 0.02 0.01"/></geometry></visual>
    <visual><origin xyz="0.2 0 0"/><geometry><cylinder radius="0.01" length="0.02"/></geometry></visual>
  </link>
  <joint name="pivot" type="revolute">
    <parent link="ground"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <clearance_pin>
    <joint name="pivot" type="planar_revolute" radial_clearance="5e-05" driven="true"/>
    <force link="arm" point="0.2 0 0" value="3 -4 0"/>
  </clearance_pin>
</robot>
"""


def _received(url: str) -> list[dict]:
    """Every message a browser receives on connecting to the view's page (its WebSocket)."""
    tornado_websocket = pytest.importorskip("tornado.websocket")
    umsgpack = pytest.importorskip("umsgpack")

    async def read() -> list[dict]:
        socket = await tornado_websocket.websocket_connect(
            url.replace("http://", "ws://").replace("/static/", "/")
        )
        messages = []
        while True:
            try:
                message = await asyncio.wait_for(socket.read_message(), 1.0)
            except TimeoutError:
                break
            if message is None:
                break
            messages.append(umsgpack.unpackb(message))
        socket.close()
        return messages

    return asyncio.run(read())


def test_skeleton_view_served_headless():
    pytest.importorskip("meshcat")
    equilibrium = clearance_pin.load(MODELS / "four_bar.urdf").solve()
    with show_equilibrium(equilibrium) as view:
        assert view.url.startswith("http://127.0.0.1:")
        assert not view.meshes  # the bundled models have no visual geometry: the skeleton
        process = view.viewer.window.server_proc
        messages = _received(view.url)
        objects = {m["path"] for m in messages if m["type"] == "set_object"}
        root = "/meshcat/four_bar/skeleton"
        assert f"{root}/nominal" in objects
        settled = {p for p in objects if p.startswith(f"{root}/settled/")}
        assert len(settled) == 5  # the links: ground, crank, coupler (2 segments), rocker
        for joint in ("crank_pivot", "pin_A", "rocker_pivot", "pin_B"):
            assert f"{root}/joints/{joint}" in objects and f"{root}/play/{joint}" in objects
        contacts = {p for p in objects if p.startswith(f"{root}/contacts/")}
        assert len(contacts) == len(equilibrium.active_contacts)
        assert "set_object" in view.scene_html() or len(view.scene_html()) > 10_000
    assert process.poll() is not None  # stopped


def test_visual_meshes_at_the_magnified_pose(tmp_path):
    pytest.importorskip("meshcat")
    urdf = tmp_path / "boxes.urdf"
    urdf.write_text(BOXES)
    equilibrium = clearance_pin.load(urdf).solve()
    with show_equilibrium(equilibrium, magnification=100.0, show_skeleton=False) as view:
        assert view.meshes and view.magnification == 100.0
        messages = _received(view.url)
    objects = [m for m in messages if m["type"] == "set_object"]
    transforms = {m["path"]: np.array(m["matrix"]).reshape(4, 4).T
                  for m in messages if m["type"] == "set_transform"}  # fmt: skip
    visuals = [m["path"] for m in objects if "/visuals/" in m["path"]]
    assert len(visuals) == 2
    assert not any("/skeleton/" in m["path"] for m in objects)
    mechanism = equilibrium.mechanism
    nominal = equilibrium.configuration.oMi[1]
    settled = equilibrium.body_placements[1]
    # the box's centre (0.1 m along the arm) is shown displaced 100 times its settled motion
    box = next(p for p in visuals if p.endswith("_0"))
    centre = transforms[box][:3, 3]
    expected = nominal.act(np.array([0.1, 0, 0]))
    moved = settled.act(np.array([0.1, 0, 0]))
    np.testing.assert_allclose(centre, expected + 100.0 * (moved - expected), atol=1e-12)
    assert np.linalg.norm(moved - expected) > 1e-6  # it did move
    assert mechanism.model.njoints == 2


def test_meshes_with_a_clearance_file_beside_the_urdf(tmp_path):
    """The headline workflow, a vendor URDF and a clearance file beside it: the view shows the
    URDF's visual geometry (it showed the skeleton alone: the source 'urdf + toml' is no file)."""
    pytest.importorskip("meshcat")
    urdf = tmp_path / "boxes.urdf"
    block = BOXES[BOXES.index("  <clearance_pin>") : BOXES.index("</clearance_pin>") + 17]
    urdf.write_text(BOXES.replace(block, ""))
    clearances = tmp_path / "play.xml"
    clearances.write_text(block.strip())
    mechanism = clearance_pin.load(urdf, clearances=clearances)
    assert " + " in mechanism.source
    with show_equilibrium(mechanism.solve(), show_skeleton=False) as view:
        assert view.meshes
        messages = _received(view.url)
    assert sum("/visuals/" in m["path"] for m in messages if m["type"] == "set_object") == 2


def test_magnified_motion_is_the_identity_at_m_1_and_affine():
    nominal = pin.SE3(pin.utils.rpyToMatrix(0.1, 0.2, 0.3), np.array([0.1, 0.2, 0.3]))
    motion = pin.exp6(np.array([1e-5, -2e-5, 3e-5, 1e-4, 2e-4, -1e-4]))
    settled = motion * nominal
    np.testing.assert_allclose(magnified_motion(nominal, settled, 1.0), motion.homogeneous,
                               atol=1e-15)  # fmt: skip
    point = np.array([0.3, -0.1, 0.2, 1.0])
    shown = magnified_motion(nominal, settled, 50.0) @ point
    np.testing.assert_allclose(
        shown[:3], point[:3] + 50.0 * (motion.act(point[:3]) - point[:3]), atol=1e-15
    )


def test_missing_meshcat_says_what_to_install(monkeypatch):
    equilibrium = clearance_pin.load(MODELS / "four_bar.urdf").solve()
    monkeypatch.setitem(sys.modules, "meshcat", None)  # as if it were not installed
    with pytest.raises(clearance_pin.ClearancePinError, match=r"pip install clearance_pin\[viz\]"):
        show_equilibrium(equilibrium)


def test_not_imported_by_default():
    import subprocess
    import sys

    code = (
        "import sys, clearance_pin, clearance_pin.plot; "
        "print(any(m.split('.')[0] in ('matplotlib', 'meshcat') for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _matrices(messages: list[dict]) -> dict[str, np.ndarray]:
    """The last transform sent to each path (three.js reads the list column-major)."""
    return {m["path"]: np.array(m["matrix"]).reshape(4, 4).T
            for m in messages if m["type"] == "set_transform"}  # fmt: skip


def _as_threejs(matrix: np.ndarray) -> np.ndarray:
    """What three.js keeps of a node matrix: decomposed into position, quaternion, scale and
    composed again (a shear is lost)."""
    return compose_trs(*decompose_trs(matrix))


def _boxes(tmp_path) -> clearance_pin.Mechanism:
    urdf = tmp_path / "boxes.urdf"
    urdf.write_text(BOXES)
    return clearance_pin.load(urdf)


def _coupler_box(mechanism) -> pin.GeometryModel:
    """A visual model for the four-bar (its URDF has none): a box on the coupler, 0.1 m long."""
    coal = pytest.importorskip("coal")
    geometry = pin.GeometryModel()
    joint = mechanism.model.getJointId("pin_A")
    placement = pin.SE3(pin.utils.rpyToMatrix(0.3, 0.2, 0.1), np.array([0.05, 0.01, 0.0]))
    geometry.addGeometryObject(
        pin.GeometryObject("coupler_box", joint, placement, coal.Box(0.1, 0.02, 0.01))
    )
    return geometry


def test_parts_are_drawn_by_the_exact_affine_map():
    """At m = 1000 the map I + m (R - I) of the turning coupler is no rotation (it stretches
    the part across the pin's axis): the node and its <object> together carry it exactly
    through three.js's decomposition (one node matrix alone would lose part of it)."""
    pytest.importorskip("meshcat")
    mechanism = clearance_pin.load(MODELS / "four_bar.urdf")
    equilibrium = mechanism.solve()
    geometry = _coupler_box(mechanism)
    m = 1000.0
    with show_equilibrium(equilibrium, m, visual_model=geometry, show_skeleton=False) as view:
        messages = _received(view.url)
    sent = _matrices(messages)
    objects = {m_["path"]: m_ for m_ in messages if m_["type"] == "set_object"}
    node = next(p for p in objects if "/visuals/coupler_box" in p)
    intrinsic = np.array(objects[node]["object"]["object"]["matrix"]).reshape(4, 4).T
    shown = _as_threejs(sent[node]) @ _as_threejs(sent[f"{node}/<object>"])
    expected = part_matrix(equilibrium, geometry.geometryObjects[0], m) @ intrinsic
    np.testing.assert_allclose(shown, expected, atol=1e-12)
    stretch = np.linalg.svd(expected[:3, :3])[1]
    assert stretch.max() - stretch.min() > 1e-3  # not rigid
    assert np.abs(_as_threejs(expected) - expected).max() > 1e-4  # one matrix would lose it


def test_split_affine_keeps_a_reflection_and_a_stretch():
    rng = np.random.default_rng(3)
    for _ in range(20):
        matrix = np.eye(4)
        matrix[:3, :3] = rng.normal(size=(3, 3))
        matrix[:3, 3] = rng.normal(size=3)
        group, turn = split_affine(matrix)
        np.testing.assert_allclose(group @ turn, matrix, atol=1e-12)
        np.testing.assert_allclose(_as_threejs(group), group, atol=1e-12)
        np.testing.assert_allclose(turn[:3, :3] @ turn[:3, :3].T, np.eye(3), atol=1e-12)
        assert np.linalg.det(turn[:3, :3]) > 0.0


def test_legend_states_the_magnification_and_the_scale_bar(tmp_path):
    pytest.importorskip("meshcat")
    equilibrium = _boxes(tmp_path).solve()
    with show_equilibrium(equilibrium, magnification=200.0) as view:
        messages = _received(view.url)
    assert view.legend[0] == "displacements and play x200"
    assert view.bar == pytest.approx(0.0002)  # 20 % of the 0.2 m arm, / 200, rounded 1-2-5
    assert view.legend[1] == "bar: 200 um of displacement"
    assert view.legend[2] == "(drawn 40 mm)"
    assert view.legend[3] == "play 50 um drawn 10 mm"
    texts = [t["text"] for m in messages if m["type"] == "set_object"
             for t in m["object"].get("textures", []) if t.get("type") == "_text"]  # fmt: skip
    assert texts == list(view.legend)
    bar = next(m for m in messages if m["type"] == "set_object" and m["path"].endswith("/bar"))
    assert bar["object"]["geometries"][0]["height"] == pytest.approx(200.0 * view.bar)


def test_trajectory_plays_one_step_per_answer(tmp_path):
    """show_trajectory: one discrete key per answer; at step k each part's node and <object>
    compose to the affine map of answer k, at one magnification for the whole path (the
    largest displacement along it at about 5 % of the size); the skeleton of answer k is
    visible at step k only."""
    pytest.importorskip("meshcat")
    mechanism = _boxes(tmp_path)
    turns = np.linspace(0.0, 1.5, 4).reshape(-1, 1)
    batch = mechanism.solve_many(configurations=turns)
    answers = list(batch)
    with show_trajectory(batch, fps=2.0) as view:
        messages = _received(view.url)
    assert view.frames == 4
    bones = [skeleton(a) for a in answers]
    largest = max(b.largest_displacement() for b in bones)
    assert view.magnification == nice_round(0.05 * max(b.size() for b in bones) / largest)
    assert f"x{view.magnification:g}" in view.legend[0]
    (animation,) = [m for m in messages if m["type"] == "set_animation"]
    clips = {a["path"]: a["clip"] for a in animation["animations"]}
    objects = {m["path"]: m for m in messages if m["type"] == "set_object"}
    geometry = pin.buildGeomFromUrdf(
        mechanism.model, str(tmp_path / "boxes.urdf"), pin.GeometryType.VISUAL
    )

    def at(path: str, step: int) -> np.ndarray:
        tracks = {t["name"]: t for t in clips[path]["tracks"]}
        assert clips[path]["fps"] == 2.0
        for track in tracks.values():
            assert [k["time"] for k in track["keys"]] == [0, 1, 2, 3]
            assert track["interpolation"] == 2300  # discrete: no blend between answers
        return compose_trs(*(tracks[f".{p}"]["keys"][step]["value"]
                             for p in ("position", "quaternion", "scale")))  # fmt: skip

    for k, answer in enumerate(answers):
        for j, obj in enumerate(geometry.geometryObjects):
            node = f"/meshcat/boxes/visuals/arm_{j}"
            intrinsic = np.array(objects[node]["object"]["object"]["matrix"]).reshape(4, 4).T
            expected = part_matrix(answer, obj, view.magnification) @ intrinsic
            np.testing.assert_allclose(at(node, k) @ at(f"{node}/<object>", k), expected,
                                       atol=1e-12)  # fmt: skip
        visible = {t["name"]: t for t in clips[f"/meshcat/boxes/skeleton/{k}"]["tracks"]}
        keys = {key["time"]: key["value"] for key in visible[".visible"]["keys"]}
        assert keys[k] is True and all(v is False for t, v in keys.items() if t != k)
    # the settled arm at step 3 is turned 1.5 rad: its tip follows the driven joint
    tip = part_matrix(answers[3], geometry.geometryObjects[1], 1.0)[:3, 3]
    np.testing.assert_allclose(tip[:2], 0.2 * np.array([np.cos(1.5), np.sin(1.5)]), atol=1e-3)


def test_viser_moves_every_vertex_by_the_affine_map(tmp_path):
    pytest.importorskip("viser")
    trimesh = pytest.importorskip("trimesh")
    equilibrium = _boxes(tmp_path).solve()
    m = 300.0
    with show_equilibrium(equilibrium, magnification=m, backend="viser") as view:
        assert view.backend == "viser" and view.url.startswith("http://127.0.0.1:")
        assert view.legend[0] == "displacements and play x300"
        box = np.asarray(view.handles["/boxes/visuals/arm_0"].vertices, dtype=float)
    nominal = equilibrium.configuration.oMi[1] * pin.SE3(np.eye(3), np.array([0.1, 0, 0]))
    settled = equilibrium.body_placements[1] * pin.SE3(np.eye(3), np.array([0.1, 0, 0]))
    local = trimesh.creation.box(extents=[0.2, 0.02, 0.01]).vertices
    start = np.array([nominal.act(v) for v in local])
    moved = np.array([settled.act(v) for v in local])
    np.testing.assert_allclose(box, start + m * (moved - start), atol=1e-6)  # float32 vertices
    assert np.abs(moved - start).max() * m > 1e-3  # drawn millimetres away


def test_unknown_backend_and_missing_viser(tmp_path, monkeypatch):
    equilibrium = clearance_pin.load(MODELS / "four_bar.urdf").solve()
    with pytest.raises(clearance_pin.ArgumentError, match="backend"):
        show_equilibrium(equilibrium, backend="gepetto")
    monkeypatch.setitem(sys.modules, "viser", None)
    with pytest.raises(clearance_pin.ClearancePinError, match=r"clearance_pin\[viser\]"):
        show_equilibrium(equilibrium, backend="viser")


def test_a_skeleton_alone_is_not_called_parts_at_true_size():
    """A URDF without visual geometry (the bundled arm) is drawn as its skeleton: the legend
    says so instead of "parts at true size" (found by a new user), and a model with parts says
    that a gap between them is their magnified play."""
    pytest.importorskip("meshcat")
    equilibrium = clearance_pin.load(MODELS / "arm_6r.urdf").solve()
    with show_equilibrium(equilibrium) as view:
        legend = view.legend
    assert "skeleton only: no meshes" in legend
    assert "parts at true size" not in legend

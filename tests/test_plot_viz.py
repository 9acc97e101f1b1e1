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
from clearance_pin.plot import show_equilibrium
from clearance_pin.plot.viz import magnified_motion

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

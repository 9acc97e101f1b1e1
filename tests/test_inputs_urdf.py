"""Real URDF files (issue 10, finding 8): encodings, mimic joints, collision meshes.

- A file in ISO-8859-1 with its declaration loads (it was a UnicodeDecodeError traceback) and
  solves exactly as its UTF-8 twin; bytes that do not match the declared encoding are a ModelError.
- A mimic joint follows its driven leader (a passive leader ties the two free joints).
- Collision meshes are read only when a check needs them: a URDF whose mesh is missing loads and
  solves, and check() raises a ModelError naming the link and the mesh file and saying how to
  point at it; package_dirs, ROS_PACKAGE_PATH and --package-dir find it.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from conftest import MODELS

import clearance_pin as cp
from clearance_pin.cli import main

LATIN1_COMMENT = (
    "<!-- Arbre sur rotule et linéaire annulaire, jeu radial ± 0,1 mm; façon Younes -->"
)


def _latin1_twin(tmp_path):
    """younes_sphere_cylinder.urdf re-encoded as ISO-8859-1, with a non-ASCII comment and robot
    name; returns (utf-8 path, latin-1 path)."""
    text = (MODELS / "younes_sphere_cylinder.urdf").read_text()
    text = text.replace('<?xml version="1.0"?>', '<?xml version="1.0" encoding="ISO-8859-1"?>')
    text = text.replace('<robot name="younes_sphere_cylinder">', '<robot name="arbre_é">')
    text = text.replace('<link name="ground"/>', f'{LATIN1_COMMENT}\n  <link name="ground"/>')
    latin = tmp_path / "arbre_latin1.urdf"
    latin.write_bytes(text.encode("iso-8859-1"))
    utf8 = tmp_path / "arbre_utf8.urdf"
    utf8.write_bytes(text.replace("ISO-8859-1", "UTF-8").encode("utf-8"))
    return utf8, latin


def test_iso_8859_1_file_loads_and_solves_as_its_utf8_twin(tmp_path):
    """The declaration is honoured: the name reads 'arbre_é', and the equilibrium is the same
    as that of the UTF-8 file to round-off."""
    utf8, latin = _latin1_twin(tmp_path)
    assert b"\xe9" in latin.read_bytes()  # really Latin-1 (0xE9), not UTF-8 (0xC3 0xA9)
    with pytest.raises(UnicodeDecodeError):
        latin.read_text(encoding="utf-8")  # what the reader used to do
    from_latin, from_utf8 = cp.load(latin), cp.load(utf8)
    assert from_latin.name == from_utf8.name == "arbre_é"
    a, b = from_latin.solve(), from_utf8.solve()
    assert a.ok and b.ok
    for joint in ("I1", "I2"):
        np.testing.assert_allclose(a.torsor(joint), b.torsor(joint), rtol=0, atol=1e-15)
    from_bytes = cp.loads(latin.read_bytes(), source=str(latin))
    assert from_bytes.name == "arbre_é"


def test_utf16_file_with_a_byte_order_mark_loads(tmp_path):
    """UTF-16 with its BOM and declaration: also decoded as declared."""
    text = (MODELS / "four_bar.urdf").read_text()
    text = text.replace('<?xml version="1.0"?>', '<?xml version="1.0" encoding="UTF-16"?>')
    path = tmp_path / "four_bar_utf16.urdf"
    path.write_bytes(text.encode("utf-16"))
    assert cp.load(path).solve().ok


def test_bytes_that_do_not_match_the_declaration_are_a_model_error(tmp_path):
    """Latin-1 bytes in a file that declares (or defaults to) UTF-8: a ModelError on <xml>."""
    _, latin = _latin1_twin(tmp_path)
    wrong = tmp_path / "wrong.urdf"
    wrong.write_bytes(latin.read_bytes().replace(b'encoding="ISO-8859-1"', b'encoding="UTF-8"'))
    with pytest.raises(cp.ModelError) as caught:
        cp.load(wrong)
    assert caught.value.element == "<xml>" and str(wrong) in str(caught.value)


MIMIC_URDF = """<robot name="gripper">
  <link name="palm"/><link name="left"/><link name="right"/>
  <joint name="left_finger" type="prismatic">
    <parent link="palm"/><child link="left"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="20" velocity="0.2"/>
  </joint>
  <joint name="right_finger" type="prismatic">
    <parent link="palm"/><child link="right"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" effort="20" velocity="0.2"/>
    <mimic joint="left_finger" multiplier="1"/>
  </joint>
  <clearance_pin><joint name="left_finger" driven="true" q="0.01"/></clearance_pin>
</robot>"""


def test_a_mimic_joint_follows_its_driven_leader():
    """A <mimic> joint is read (issue 23): the follower is held at its driven leader's value;
    with a passive leader both stay free, tied by the coupling (never ignored: the follower
    still sits at m x leader + o)."""
    gripper = cp.loads(MIMIC_URDF, source="gripper.urdf")
    model = gripper.model
    right = model.joints[model.getJointId("right_finger")].idx_q
    assert gripper.q_nominal[right] == 0.01 and gripper.joint("right_finger").driven
    passive = cp.loads(MIMIC_URDF.replace(' driven="true"', ""), source="gripper.urdf")
    assert not passive.joint("right_finger").driven and not passive.joint("left_finger").driven
    assert passive.q_nominal[right] == 0.01
    assert [(c.follower, c.leader) for c in passive.couplings] == [("right_finger", "left_finger")]


# a closed tetrahedron, 1 mm, ASCII STL
STL = """solid probe
facet normal 0 0 -1
outer loop
vertex 0 0 0
vertex 0 0.001 0
vertex 0.001 0 0
endloop
endfacet
facet normal 0 -1 0
outer loop
vertex 0 0 0
vertex 0.001 0 0
vertex 0 0 0.001
endloop
endfacet
facet normal -1 0 0
outer loop
vertex 0 0 0
vertex 0 0 0.001
vertex 0 0.001 0
endloop
endfacet
facet normal 1 1 1
outer loop
vertex 0.001 0 0
vertex 0 0.001 0
vertex 0 0 0.001
endloop
endfacet
endsolid probe
"""
MESH = "package://bearing_parts/meshes/bore.stl"


def _with_missing_mesh(tmp_path):
    """younes_sphere_cylinder.urdf whose ground_I2 link carries a package:// mesh that is not
    on this machine; the shaft_I2 link a cylinder."""
    text = (MODELS / "younes_sphere_cylinder.urdf").read_text()
    text = text.replace(
        '<link name="ground_I2"/>',
        f'<link name="ground_I2"><collision><geometry><mesh filename="{MESH}"/></geometry>'
        "</collision></link>",
    )
    text = text.replace(
        '<link name="shaft_I2"/>',
        '<link name="shaft_I2"><collision><origin rpy="0 1.5707963267948966 0"/><geometry>'
        '<cylinder radius="0.005" length="0.04"/></geometry></collision></link>',
    )
    path = tmp_path / "urdf" / "shaft.urdf"
    path.parent.mkdir()
    path.write_text(text)
    return path


def _package(tmp_path):
    """A directory holding the package bearing_parts with its mesh."""
    root = tmp_path / "workspace"
    (root / "bearing_parts" / "meshes").mkdir(parents=True)
    (root / "bearing_parts" / "meshes" / "bore.stl").write_text(STL)
    return root


def test_missing_mesh_solves_and_check_names_it(tmp_path, monkeypatch):
    """Loading and solving read no mesh; check() raises a ModelError naming the link, the mesh
    file, package_dirs, --package-dir and ROS_PACKAGE_PATH."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    mechanism = cp.load(_with_missing_mesh(tmp_path))
    result = mechanism.solve()
    assert result.ok
    pickle.loads(pickle.dumps(mechanism))  # the unbuilt geometry pickles
    with pytest.raises(cp.ModelError) as caught:
        result.check()
    error = caught.value
    assert error.element == f"<link name='ground_I2'> <collision> <mesh filename='{MESH}'>"
    for hint in ("package_dirs", "--package-dir", "ROS_PACKAGE_PATH"):
        assert hint in error.problem
    with pytest.raises(cp.ModelError):
        _ = mechanism.collision_model  # asked again, the same clear error


def test_package_dirs_find_the_mesh(tmp_path, monkeypatch):
    """package_dirs=[dir] (dir holds bearing_parts/) or ROS_PACKAGE_PATH=dir: the mesh is found
    and the check runs."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    path, root = _with_missing_mesh(tmp_path), _package(tmp_path)
    mechanism = cp.load(path, package_dirs=[root])
    assert mechanism.collision_model.ngeoms == 2
    assert "I2" in mechanism.solve().check().joints
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(root))
    assert cp.load(path).collision_model.ngeoms == 2


def test_cli_package_dir(tmp_path, monkeypatch, capsys):
    """clearance-pin solve works without the mesh (exit 0); --check without it exits 2 with
    one line naming the mesh; --package-dir DIR (repeatable) finds it."""
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    path, root = _with_missing_mesh(tmp_path), _package(tmp_path)
    assert main(["solve", str(path)]) == 0
    capsys.readouterr()
    assert main(["solve", str(path), "--check"]) == 2
    assert MESH in capsys.readouterr().err
    other = tmp_path / "elsewhere"
    other.mkdir()
    code = main(
        ["solve", str(path), "--check", "--package-dir", str(other), "--package-dir", str(root)]
    )
    assert code in (0, 1)  # the check ran (its verdict on a 1 mm tetrahedron is not the point)
    assert "not found" not in capsys.readouterr().err

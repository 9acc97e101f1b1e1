"""Surface checks: journals in generated faceted bores, and the URDF's own collision parts."""

from __future__ import annotations

import sys
import tomllib
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import clearance_pin as cp
from clearance_pin.check.geometry import faceting_bound, tangent_polygon
from clearance_pin.model.builders import JointSpec, shaft_urdf

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "validation"))
from younes2013 import build  # noqa: E402

CASES = {
    c["id"]: c
    for c in tomllib.loads((ROOT / "validation" / "younes2013_cases.toml").read_text())["case"]
}
JOURNAL_CASES = sorted(
    i for i, c in CASES.items() if any(j["kind"] == "cylindrical" for j in c["joint"])
)


@cache
def _solved(case_id: str):
    return build(CASES[case_id]).solve(exact=True)


@pytest.mark.parametrize("case_id", JOURNAL_CASES)
def test_generated_bores_pass_on_the_exact_pose(case_id):
    """Every journal of the paper's cases, as a cylinder of radius 10 c in a bore of 512 tangent
    facets, reads the model's gap within its one-sided tolerance, itself below 1e-3 c."""
    report = _solved(case_id).check(bores=True)
    surfaces = [s for joint in report.joints.values() for s in joint.surfaces]
    assert surfaces and report.ok, report.table()
    for reading in surfaces:
        assert reading.method == "bore N=512"
        assert reading.tolerance.total < 1e-3 * reading.clearance
        assert reading.deviation >= -reading.tolerance.below


def test_journal_radius_and_facets_are_options():
    """A thicker journal and a finer bore change the faceting and rim terms as their formulas say."""
    equilibrium = _solved("6.3.2")
    reading = equilibrium.check(bores=True, journal_radius=5e-3, facets=2048).joints["I2"]
    surface = reading.surfaces[0]
    c = 5e-5
    assert surface.tolerance.faceting == pytest.approx(faceting_bound(5e-3 + c, 2048))
    assert surface.ok


def test_linear_pose_overlaps_the_bore_on_6_1_6_1b():
    """The small-displacement pose of 6.1.6.1b pushes the journal into the bore: the surface
    reading is negative beyond its (solver + coal) tolerance, a penetration."""
    report = _solved("6.1.6.1b").linear.check(pose="as_solved", bores=True)
    surface = report.joints["I2"].surfaces[0]
    assert surface.verdict == "penetration"
    assert "deepest facet penetration" in surface.message()


def _shaft_with_parts(tmp_path: Path, facets: int) -> Path:
    """6.1.6.1b's shaft with URDF collision parts at I2: a journal cylinder (radius 10 c) on the
    shaft, and an STL bore of tangent facets on the ground, twice the journal's length."""
    c, length = 5e-5, 0.04
    radius = 10 * c
    polygon = tangent_polygon(radius + c, facets)
    lines = ["solid bore"]
    for k in range(facets):
        a0, a1 = np.r_[-length, polygon[k]], np.r_[-length, polygon[(k + 1) % facets]]
        b0, b1 = np.r_[length, polygon[k]], np.r_[length, polygon[(k + 1) % facets]]
        for triangle in ((a0, a1, b0), (b0, a1, b1)):
            lines.append(" facet normal 0 0 0\n  outer loop")
            lines += ["   vertex " + " ".join(repr(float(v)) for v in p) for p in triangle]
            lines.append("  endloop\n endfacet")
    lines.append("endsolid bore")
    (tmp_path / "bore.stl").write_text("\n".join(lines))
    text = shaft_urdf(
        JointSpec("I1", "spherical", (0.0, 0.0, 0.0), 0.003),
        JointSpec("I2", "cylindrical", (0.2, 0.0, 0.0), 2 * c, length),
        (0.3, 0.0, 0.0),
        (1.0, 1.0, 1.0),
        (0.0, 0.0, 0.0),
    )
    text = text.replace(
        '<link name="ground_I2"/>',
        '<link name="ground_I2"><collision><geometry><mesh filename="bore.stl"/></geometry>'
        "</collision></link>",
    )
    text = text.replace(
        '<link name="shaft_I2"/>',
        '<link name="shaft_I2"><collision><origin rpy="0 1.5707963267948966 0"/><geometry>'
        f'<cylinder radius="{radius!r}" length="{length!r}"/></geometry></collision></link>',
    )
    path = tmp_path / "shaft.urdf"
    path.write_text(text)
    return path


def test_urdf_parts_are_measured(tmp_path):
    """With collision geometry on both links of I2 the real parts are measured: the exact pose
    passes once the mesh's faceting bound is given (plus 1e-9 m for its float32 vertices); without
    it only penetration is judged, and the report says so."""
    facets = 256
    mechanism = cp.load(_shaft_with_parts(tmp_path, facets))
    assert mechanism.collision_model is not None
    exact = mechanism.solve(exact=True)
    bound = faceting_bound(5e-4 + 5e-5, facets) + 1e-9
    report = exact.check(mesh_faceting=bound)
    parts = report.joints["I2"].surfaces
    assert len(parts) == 1 and parts[0].method == "parts (mesh)" and report.ok
    assert 0.0 <= parts[0].distance <= bound + parts[0].tolerance.rim + 1e-12
    assert parts[0].tolerance.rim > 0.0  # the journal tilts in the bore
    assert "I1" in report.joints and not report.joints["I1"].surfaces  # no parts at I1
    unjudged = exact.check()
    assert unjudged.joints["I2"].surfaces[0].verdict == "not judged"
    assert any("mesh_faceting" in note for note in unjudged.notes)

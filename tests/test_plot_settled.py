"""The settled-pose picture (clearance_pin.plot.plot_equilibrium): produced, non-empty, and
drawing what it says: one force arrow per active contact, one play outline per joint with play,
the magnification and force scale in the title, a plane view for a planar mechanism and two 3-D
views for a spatial one."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from conftest import MODELS

pytest.importorskip("matplotlib")

import clearance_pin
from clearance_pin.plot import contact_arrows, plot_equilibrium
from clearance_pin.plot.settled import LOAD_FORCE, PLAY


def _gids(figure, gid):
    return [
        a for ax in figure.axes for a in (*ax.patches, *ax.collections, *ax.lines)
        if a.get_gid() == gid
    ]  # fmt: skip


@pytest.mark.parametrize("name", ["four_bar", "slider_crank"])
def test_planar_picture(tmp_path, name):
    equilibrium = clearance_pin.load(MODELS / f"{name}.urdf").solve()
    target = tmp_path / f"{name}.png"
    figure = plot_equilibrium(equilibrium, target)
    assert target.stat().st_size > 20_000
    assert len(figure.axes) == 1  # drawn in its plane
    ax = figure.axes[0]
    assert ax.get_xlabel() == "x [mm]" and ax.get_ylabel() == "y [mm]"
    assert len(contact_arrows(figure)) == len(equilibrium.active_contacts)
    assert len(_gids(figure, LOAD_FORCE)) == (2 if name == "slider_crank" else 1)
    title = figure.get_suptitle()
    assert name in title and "small-displacement model" in title
    assert "x50" in title or "x100" in title
    assert "1 mm =" in title
    legends = [c for c in ax.get_children() if type(c).__name__ == "Legend"]
    texts = [t.get_text() for legend in legends for t in legend.get_texts()]
    assert "nominal pose" in texts and "settled pose (magnified)" in texts
    assert any("joint play" in t for t in texts)


def test_play_outlines_and_arrow_geometry(tmp_path):
    """Every pin's play is a circle of radius m c [mm] around its settled housing; each contact
    arrow ends at its contact with the length of its force at the stated scale."""
    equilibrium = clearance_pin.load(MODELS / "four_bar.urdf").solve()
    figure = plot_equilibrium(equilibrium, magnification=200.0, force_scale=4.0)
    assert "x200" in figure.get_suptitle() and "1 mm = 4 N" in figure.get_suptitle()
    rings = _gids(figure, PLAY)
    assert len(rings) == 4
    for ring in rings:
        xy = np.asarray(ring.get_xydata())
        radius = np.linalg.norm(xy - xy[:-1].mean(axis=0), axis=1)
        np.testing.assert_allclose(radius, 200.0 * 5e-5 * 1e3, rtol=1e-9)  # 10 mm
    lengths = sorted(np.linalg.norm(np.subtract(*a._posA_posB)) for a in contact_arrows(figure))
    forces = sorted(c.force_magnitude / 4.0 for c in equilibrium.active_contacts)
    np.testing.assert_allclose(lengths, forces, rtol=1e-9)


def test_spatial_picture_two_views(tmp_path):
    equilibrium = clearance_pin.load(MODELS / "arm_6r.urdf").solve()
    target = tmp_path / "arm.png"
    figure = plot_equilibrium(equilibrium, target)
    assert target.stat().st_size > 30_000
    views = [ax for ax in figure.axes if ax.name == "3d"]
    assert len(views) == 2
    assert {ax.get_zlabel() for ax in views} == {"z [mm]"}
    assert len({(ax.elev, ax.azim) for ax in views}) == 2
    # one arrow per active contact in each view
    assert len(contact_arrows(figure)) == 2 * len(equilibrium.active_contacts)
    assert len(_gids(figure, PLAY)) == 2 * 2 * 6  # two end circles per journal, per view
    title = figure.get_suptitle()
    assert "gravity" in title and "applied forces: 1 mm =" in title


def test_exact_model_picture(tmp_path):
    equilibrium = clearance_pin.load(MODELS / "slider_crank.urdf").solve(exact=True)
    figure = plot_equilibrium(equilibrium, tmp_path / "exact.svg")
    assert "exact model" in figure.get_suptitle()
    assert (tmp_path / "exact.svg").read_text().startswith("<?xml")
    assert len(contact_arrows(figure)) == len(equilibrium.active_contacts)


def test_bad_arguments():
    equilibrium = clearance_pin.load(MODELS / "four_bar.urdf").solve()
    for bad in (0.0, -3.0, float("nan")):
        with pytest.raises(clearance_pin.ArgumentError):
            plot_equilibrium(equilibrium, magnification=bad)
    with pytest.raises(clearance_pin.ArgumentError):
        plot_equilibrium(equilibrium, force_scale=0.0)
    with pytest.raises(clearance_pin.ArgumentError):
        plot_equilibrium(equilibrium, "/nonexistent-directory/picture.png")


def test_missing_matplotlib_says_what_to_install(monkeypatch):
    equilibrium = clearance_pin.load(MODELS / "four_bar.urdf").solve()
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)  # as if it were not installed
    with pytest.raises(clearance_pin.ClearancePinError, match=r"pip install clearance_pin\[plot\]"):
        plot_equilibrium(equilibrium)

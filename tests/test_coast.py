"""Coast side of a mesh (hacgear_core.statics.coast): mapping onto drive positions from the geometry, checked against
placed flank polylines; no-load deflection = normal backlash; symmetric teeth mirror the drive FDF; the coast
tables of the 28-tooth pair (gauges, hub reactions, tooth loads, stiffness)."""
from __future__ import annotations

import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from hacgear_core.geometry import mesh_geometry
from hacgear_core.kinds import load_model
from hacgear_core.statics import (
    ContactOptions,
    MeshStaticSolver,
    compute_statics,
    describe_solver,
    make_mesh_solver,
    mesh_stiffness_report,
    model_variant,
)
from hacgear_core.statics.coast import COAST_PAIR_SHIFT, CoastSideSolver, coast_mapping, make_coast_solver
from hacgear_core.tables import read_tables

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _coast_brute import CoastClosure  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
MODEL = REPO / "models" / "spur_28t_asym" / "model.toml"
ONE_SLICE = ContactOptions(face_slices=1)


@pytest.fixture(scope="module")
def unmod():
    """The 28-tooth pair without tip relief and crowning (ideal involutes on both sides)."""
    return model_variant(load_model(MODEL), tip_relief=False, lead_crowning=False)


@pytest.fixture(scope="module")
def coast_unmod(unmod) -> CoastSideSolver:
    return make_coast_solver(unmod, "m12", options=ONE_SLICE)


@pytest.fixture(scope="module")
def drive_unmod(unmod):
    return make_mesh_solver(unmod, "m12", options=ONE_SLICE)


def test_protocol_and_mapping_from_geometry(coast_unmod):
    c = coast_unmod
    assert isinstance(c, MeshStaticSolver)
    info = describe_solver(c)
    mg = mesh_geometry(load_model(MODEL), "m12")
    assert info.side == "coast" and info.flanks == ("coast", "coast")
    assert info.base_radius_m == pytest.approx(tuple(mg.base_radius_coast_m.values()), rel=1e-12)
    assert set(info.gauge_names) == {"pinion/SG25", "pinion/SG20", "wheel/SG25", "wheel/SG20"}
    assert info.contact_deflection_m == mg.backlash_normal_m
    assert info.coast == {"backlash_normal_m": mg.backlash_normal_m, "backlash_circular_m": mg.backlash_circular_m,
                          "position_offset": mg.coast_position_offset, "pair_shift": {"pinion": 1, "wheel": 0}}
    assert c.inner.flanks == ("coast", "coast") and c.inner.base_radius_m == c.base_radius_m
    # the wrapper is the inner solver at c0 - tau, deflection shifted by the backlash, pairs reversed, hub mirrored
    tau, x = 0.3, mg.backlash_normal_m + 20e-6
    a = c.solve_deflection(tau, x)
    b = c.inner.solve_deflection(mg.coast_position_offset - tau, 20e-6)
    assert a.position == tau and a.mesh_deflection_m == pytest.approx(x, abs=1e-15)
    assert a.mesh_force_N == pytest.approx(b.mesh_force_N, rel=1e-9) and b.mesh_force_N > 0
    np.testing.assert_allclose(a.tooth_load_N, b.tooth_load_N[::-1], rtol=1e-9)
    np.testing.assert_allclose(a.strain["wheel/SG20"], b.strain["wheel/SG20"][::-1], rtol=1e-9)
    np.testing.assert_allclose(a.hub_reaction["pinion"], b.hub_reaction["pinion"] * [1, -1, -1], rtol=1e-9)
    # pair phase rule on the coast side: X_k(tau + 1) = X_{k-1}(tau)
    a1 = c.solve_deflection(tau + 1, x)
    np.testing.assert_allclose(a1.tooth_load_N[1:], a.tooth_load_N[:-1], rtol=1e-9, atol=1e-9)


def test_nlmd_equals_normal_backlash_unmodified(coast_unmod):
    """Ideal involutes: the coast flanks close after exactly the normal backlash at every position."""
    jn = coast_unmod.backlash_normal_m
    nl = np.array([coast_unmod.no_load_deflection(p) for p in np.arange(16) / 16])
    assert np.max(np.abs(nl - jn)) < 1e-6          # measured 0.004 µm


def _teeth_of_pair(k: int, sa: float, sb: float, za: int, zb: int) -> tuple[int, int]:
    """Teeth (gears' own numbering) of drive pair k: tooth 0 of both gears is pair 0 at drive position 0 and a pair
    reaches the drive pitch point k mesh cycles later (gear_a turning in its sense sa, gear_b in sb)."""
    return int((-sa * k) % za), int((-sb * k) % zb)


@pytest.mark.parametrize("case,tau", [("28t", 0.1), ("28t", 0.62), ("idler_m23", 0.37)])
def test_contact_pairs_and_roll_match_placed_flanks(unmod, coast_unmod, drive_unmod, case, tau):
    """Placed flank polylines (no solver, no closed form) decide which physical teeth touch first, where, and after
    which approach; the drive table's pair numbering and the coast table's pair_shift must name the same teeth.
    Cases: the 28-tooth pair without relief (ties: several pairs touch at once) and the idler chain's second mesh
    as modelled (gear_a turning clockwise, loaded on its 20° flanks: the drive solver's picture is mirrored)."""
    if case == "28t":
        model, mesh, drive, coast = unmod, "m12", drive_unmod, coast_unmod
    else:
        model, mesh = load_model(REPO / "models" / "idler_28_33_39" / "model.toml"), "m23"
        drive = make_mesh_solver(model, mesh, options=ONE_SLICE)       # one slice: the uncrowned face centre
        coast = make_coast_solver(model, mesh, options=ONE_SLICE)
    za, zb = drive.teeth
    ga, gb = drive.gear_names
    for side, solver in (("drive", drive), ("coast", coast)):
        brute = CoastClosure(model, mesh, side=side)
        x_first, touching = brute.close(tau)
        nl = solver.no_load_deflection(tau)
        assert x_first == pytest.approx(nl, abs=0.05e-6), side
        sol = solver.solve_deflection(tau, nl + 0.3e-6)
        shift = dict(zip(solver.gear_names, COAST_PAIR_SHIFT)) if side == "coast" else {ga: 0, gb: 0}
        got = {}
        for k, load, roll in zip(solver.tooth_offsets, sol.tooth_load_N, sol.contact_roll_deg):
            if load > 0:
                ta, _ = _teeth_of_pair(k - shift[ga], brute.sa, brute.sb, za, zb)
                _, tb = _teeth_of_pair(k - shift[gb], brute.sa, brute.sb, za, zb)
                got[(ta, tb)] = roll
        assert set(got) == set(touching), (side, got, touching)
        for pair, (_, roll) in touching.items():
            assert got[pair] == pytest.approx(roll, abs=0.05), (side, pair)


# ----------------------------------------------------------------------------------------------
# tables of both sides
# ----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def asym_tables(tmp_path_factory):
    d = tmp_path_factory.mktemp("asym")
    shutil.copy(MODEL, d / "model.toml")
    compute_statics(d / "model.toml", d / "t.h5", positions=8, loads=6, deflections=24, workers=1, progress=False)
    return read_tables(d / "t.h5", d / "model.toml").mesh("m12")


def test_coast_gauges_tension_and_compression(asym_tables):
    """Coast load (20° flank) bends the tooth the other way: the 20° root gauge (SG20) in tension, the 25° root
    gauge (SG25) in compression, on both gears; the drive side the opposite."""
    d, c = asym_tables, asym_tables.coast
    for gear in ("pinion", "wheel"):
        sg20, sg25 = c.strain[f"{gear}/SG20"], c.strain[f"{gear}/SG25"]
        assert sg20.max() > 1000e-6 and sg20.max() > 20 * -sg20.min()
        assert sg25.min() < -1000e-6 and -sg25.min() > 20 * sg25.max()
        d20, d25 = d.strain[f"{gear}/SG20"], d.strain[f"{gear}/SG25"]
        assert d25.max() > 20 * -d25.min() and -d20.min() > 20 * d20.max()


def test_coast_hub_reactions_equilibrium_and_tooth_loads(asym_tables):
    d, c = asym_tables, asym_tables.coast
    Ha, Hb = c.hub_reaction["pinion"], c.hub_reaction["wheel"]
    F = c.force_N
    loaded = F > 0.01 * F.max()
    np.testing.assert_allclose(Ha[..., :2] + Hb[..., :2], 0.0, atol=1e-9 * F.max())
    rba, rbb = c.base_radius_m
    # the mesh force is the force conjugate to the approach: W = (T_a / r_b1 + T_b / r_b2) / 2
    W = 0.5 * (np.abs(Ha[..., 2]) / rba + np.abs(Hb[..., 2]) / rbb)
    np.testing.assert_allclose(W[loaded], F[loaded], rtol=1e-9)
    # the coast contact turns both hubs the other way than the drive contact
    dl = d.force_N > 0.01 * d.force_N.max()
    assert np.all(Ha[loaded, 2] > 0) and np.all(d.hub_reaction["pinion"][dl, 2] < 0)
    assert np.all(Hb[loaded, 2] > 0) and np.all(d.hub_reaction["wheel"][dl, 2] < 0)
    # tooth loads sum to the mesh force (contact normals within 1 % of the line of action on the relieved flanks)
    np.testing.assert_allclose(c.tooth_load_N.sum(axis=2)[loaded], F[loaded], rtol=0.01)


def test_coast_table_grid_starts_below_the_backlash(asym_tables):
    c = asym_tables.coast
    jn = c.backlash_normal_m
    assert jn == pytest.approx(mesh_geometry(load_model(MODEL), "m12").backlash_normal_m, rel=1e-15)
    assert c.no_load_deflection_m.min() == pytest.approx(jn, abs=0.01e-6)  # involute contact somewhere in the cycle
    assert np.all(c.no_load_deflection_m >= jn - 1e-9)                      # relief only opens the gap
    # first column one step below min(j_n, min NLMD): no force there, nor below the grid
    assert c.deflection_m[1] == min(jn, c.no_load_deflection_m.min()) and np.all(c.force_N[:, :2] == 0)
    assert c.static_deflection_m[:, -1].max() < c.deflection_m[-1]


@pytest.fixture(scope="module")
def sym_tables(tmp_path_factory):
    """The 50-tooth pair of Table 3.1: symmetric 20° teeth, no relief."""
    d = tmp_path_factory.mktemp("sym")
    shutil.copy(REPO / "models" / "spur_50t_icr137" / "model.toml", d / "model.toml")
    compute_statics(d / "model.toml", d / "t.h5", positions=8, loads=4, deflections=32, workers=1, progress=False)
    return read_tables(d / "t.h5", d / "model.toml").mesh("m12")


def test_symmetric_teeth_coast_fdf_is_the_mirrored_drive_fdf(sym_tables):
    """Symmetric teeth: the coast FDF at drive position tau and approach x equals the drive FDF at the mirrored
    position c0 - tau and deflection x - j_n (the coast flank pair is the drive pair's mirror image)."""
    d, c = sym_tables, sym_tables.coast
    c0, jn = c.position_offset, c.backlash_normal_m
    assert c0 == pytest.approx(-0.5, abs=1e-12) and jn == pytest.approx(0.136047e-3, rel=1e-5)
    ref = d.force(c0 - c.position[:, None], c.deflection_m[None, :] - jn)
    assert np.max(np.abs(c.force_N - ref)) < 0.005 * d.force_N.max()
    np.testing.assert_allclose(c.no_load_deflection_m, d.no_load_deflection(c0 - c.position) + jn, atol=0.02e-6)


def test_coast_stiffness_of_the_20_degree_flanks(capsys):
    """Mean mesh stiffness at 300 N·m, 16 positions: drive (25°) and coast (20°) side of the 28-tooth pair
    (docs/validation.md: drive 164.46e6, coast 157.91e6 N/m at 64 positions); the coast side through the CLI."""
    import json

    from hacgear_core.cli import main

    drive = mesh_stiffness_report(load_model(MODEL), 300.0, positions=16)["meshes"]["m12"]
    assert main(["stiffness", str(MODEL), "--side", "coast", "--positions", "16", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    coast = rep["meshes"]["m12"]
    assert rep["side"] == coast["side"] == "coast" and coast["flanks"] == ["coast", "coast"]
    assert coast["mesh_force_N"] == pytest.approx(300.0 / coast["base_radius_m"][0], rel=1e-12)
    assert coast["base_radius_m"][0] == pytest.approx(0.07 * math.cos(math.radians(20.0)), rel=1e-9)
    kd, kc = drive["mean_mesh_stiffness_N_per_m"], coast["mean_mesh_stiffness_N_per_m"]
    assert kd == pytest.approx(164.46e6, rel=0.03) and kc == pytest.approx(157.91e6, rel=0.03)
    assert coast["backlash_normal_m"] == pytest.approx(402.15e-6, abs=0.01e-6)
    # positions: the coast pair's own (pitch point at 0), and where that is on the drive side (c0 - tau)
    assert coast["mesh_cycle_drive"][0] == pytest.approx(0.5) and coast["mesh_cycle"][0] == 0.0


def test_coast_mapping_of_a_mirrored_mesh():
    """The idler chain's second mesh loads the 20° ("coast") flanks: its coast side is the 25° ("drive") pair."""
    m = load_model(REPO / "models" / "idler_28_33_39" / "model.toml")
    mp = coast_mapping(m, "m23")
    mg = mesh_geometry(m, "m23")
    assert mp.flanks == ("drive", "drive") and mp.pair_shift == {"gear2": 1, "gear3": 0}
    assert mp.backlash_normal_m == pytest.approx(mg.backlash_circular_m * math.cos(math.radians(25.0)), rel=1e-9)


def test_internal_mesh_coast_side():
    """Ring-planet mesh (internal): the coast side by the same code; ideal involutes close after
    exactly j_n; under coast load the ring and planet get equal and opposite forces, torques opposite to drive."""
    m = model_variant(load_model(REPO / "models" / "planetary_65_55_175" / "model.toml"), tip_relief=False,
                      lead_crowning=False)
    c = make_coast_solver(m, "ring_planet", options=ONE_SLICE)
    d = make_mesh_solver(m, "ring_planet", options=ONE_SLICE)
    mesh = {x.name: x for x in m.meshes}["ring_planet"]
    other = {"drive": "coast", "coast": "drive"}
    assert c.flanks == (other[mesh.flank_a], other[mesh.flank_b]) and c.inner.internal
    nl = np.array([c.no_load_deflection(p) for p in (0.0, 0.25, 0.5, 0.75)])
    assert np.max(np.abs(nl - c.backlash_normal_m)) < 1e-6      # measured 0.001 µm
    sc, sd = c.solve_load(0.3, 2000.0), d.solve_load(0.3, 2000.0)
    assert sc.mesh_deflection_m > c.backlash_normal_m and sum(sc.tooth_load_N) == pytest.approx(2000.0, rel=0.01)
    hc, hd = sc.hub_reaction, sd.hub_reaction
    np.testing.assert_allclose(hc["ring"][:2] + hc["planet"][:2], 0.0, atol=1e-9)
    assert np.sign(hc["ring"][2]) == -np.sign(hd["ring"][2]) and np.sign(hc["planet"][2]) == -np.sign(hd["planet"][2])

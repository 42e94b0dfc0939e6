"""Tests of hacgear_core.geometry.train: gear placement, senses, line-of-action vectors, mesh phases, torque flow."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hacgear_core.geometry import gear_geometry, mesh_geometry, nominal_mesh_forces, train_geometry
from hacgear_core.kinds import load_model


def _distance_to_polyline(p: np.ndarray, poly: np.ndarray) -> float:
    a, b = poly[:-1], poly[1:]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return float(np.min(np.hypot(*(a + t[:, None] * ab - p).T)))


def _brute_force_phase(model, train, mesh_name: str, n_scan: int = 400) -> float:
    """Mesh position of ``mesh_name`` when the first mesh is at 0, found by placing the generated flank polylines
    (not the involute formula): gear_a of the mesh is turned from its assembly angle in its sense until some
    tooth's loaded flank polyline passes through the mesh's pitch point; the position then is an integer."""
    me = model.mesh(mesh_name)
    gg = gear_geometry(model.gear(me.gear_a))
    flank = gg.flank(me.flank_a, n=400)
    inv = flank.region == 2
    poly0 = flank.xy[inv]
    pitch = train.meshes[mesh_name].pitch_point_m - train.centre_m[me.gear_a]
    sense = train.sense[me.gear_a]
    phi0 = train.assembly_angle_rad[me.gear_a]
    z = gg.z

    def dist(turn):
        best = math.inf
        for k in range(z):
            ang = phi0 + sense * turn + 2 * math.pi * k / z
            c, s = math.cos(ang), math.sin(ang)
            poly = poly0 @ np.array([[c, s], [-s, c]])
            if np.min(np.hypot(*(poly - pitch).T)) < 0.02:
                best = min(best, _distance_to_polyline(pitch[None, :], poly))
        return best

    pitch_angle = 2 * math.pi / z
    turns = np.linspace(0.0, pitch_angle, n_scan, endpoint=False)
    d = np.array([dist(t) for t in turns])
    i = int(np.argmin(d))
    # refine: the distance is |linear| near the crossing; golden search on a bracket
    lo, hi = turns[i] - pitch_angle / n_scan, turns[i] + pitch_angle / n_scan
    for _ in range(60):
        m1, m2 = lo + (hi - lo) * 0.382, lo + (hi - lo) * 0.618
        if dist(m1) < dist(m2):
            hi = m2
        else:
            lo = m1
    turn = 0.5 * (lo + hi)
    return (-turn * z / (2 * math.pi)) % 1.0


def test_idler_mesh_phase_equals_a_brute_force_placement():
    model = load_model("idler_28_33_39")
    train = train_geometry(model)
    assert train.meshes["m12"].phase == 0.0
    ph = train.meshes["m23"].phase
    bf = _brute_force_phase(model, train, "m23")
    d = (ph - bf + 0.5) % 1.0 - 0.5
    assert abs(d) < 1e-3, (ph, bf)


def test_phase_follows_the_line_of_centres():
    """Turning the second line of centres by one tooth pitch of the idler leaves the phase unchanged; by half a pitch
    shifts it by half a mesh cycle (z_2 = 33 teeth)."""
    import dataclasses

    model = load_model("idler_28_33_39")
    base = train_geometry(model).meshes["m23"].phase

    def phase(deg):
        meshes = tuple(dataclasses.replace(m, line_of_centres_rad=math.radians(deg)) if m.name == "m23" else m
                       for m in model.meshes)
        return train_geometry(dataclasses.replace(model, meshes=meshes)).meshes["m23"].phase

    pitch_deg = 360.0 / 33
    assert (phase(pitch_deg) - base + 0.5) % 1.0 - 0.5 == pytest.approx(0.0, abs=1e-9)
    assert (phase(0.5 * pitch_deg) - base) % 1.0 == pytest.approx(0.5, abs=1e-9)


def test_senses_lines_of_action_and_moment_arms():
    model = load_model("idler_28_33_39")
    tg = train_geometry(model)
    assert tg.sense == {"gear1": 1.0, "gear2": -1.0, "gear3": 1.0}
    for name, pl in tg.meshes.items():
        mg = mesh_geometry(model, name)
        assert np.linalg.norm(pl.line_of_action) == pytest.approx(1.0, abs=1e-15)
        # the line of action is tangent to both base circles and makes the operating pressure angle with the
        # tangent to the pitch circles
        for g in (pl.gear_a, pl.gear_b):
            assert abs(pl.moment_arm_m[g]) == pytest.approx(mg.base_radius_m[g], rel=1e-12)
            assert math.copysign(1.0, pl.moment_arm_m[g]) == tg.sense[g]
        e = tg.centre_m[pl.gear_b] - tg.centre_m[pl.gear_a]
        e /= np.linalg.norm(e)
        assert abs(float(pl.line_of_action @ e)) == pytest.approx(math.sin(mg.operating_pressure_angle_rad), rel=1e-12)
    # speed ratios: kinematic, each gear's teeth passing at the same mesh frequency
    assert tg.speed_ratio["gear3"] == pytest.approx(28 / 39, rel=1e-12)
    assert tg.centre_m["gear3"] == pytest.approx([0.1525 + 0.180, 0.0], abs=1e-12)


def test_torque_flow_through_the_idler():
    """The idler carries F_s1 r_12 = F_s2 r_21: the second mesh sees 300 N*m x r_b(gear2, 25 deg)/r_b(gear1, 25 deg)
    referred to gear 2 (~354 N*m), not 300."""
    model = load_model("idler_28_33_39")
    f = nominal_mesh_forces(model)
    rb = {g.name: gear_geometry(g).base_radius_m for g in model.gears}
    assert f["m12"] == pytest.approx(300.0 / rb["gear1"]["drive"], rel=1e-12)
    assert f["m12"] * rb["gear2"]["drive"] == pytest.approx(f["m23"] * rb["gear2"]["coast"], rel=1e-12)
    assert f["m23"] * rb["gear2"]["coast"] == pytest.approx(353.57, abs=0.01)
    assert nominal_mesh_forces(model, torque_Nm=150.0)["m23"] == pytest.approx(0.5 * f["m23"], rel=1e-12)

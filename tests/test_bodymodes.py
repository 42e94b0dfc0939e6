"""Tests of the reduced elastic gear body (hacgear_core.statics.bodymodes): mass matrix against closed forms,
mode normalisation, convergence of the first body mode with the mesh, residual compliance positive semidefinite."""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
from _fe_synthetic_gear import SyntheticGear  # noqa: E402

from hacgear_core.errors import ModelError  # noqa: E402
from hacgear_core.statics.bodymodes import BodyModeOptions, gear_body_modes  # noqa: E402
from hacgear_core.statics.fe import ElasticMaterial, MeshOptions, PlaneFE, gear_compliance  # noqa: E402

MAT = ElasticMaterial(2.0e11, 0.3)
RHO = 7850.0
COARSE = MeshOptions(flank_size_m=1.0e-3, fillet_size_m=1.0e-3, body_size_m=4e-3)


def _annulus(ri, ro, nr=4, nt=48):
    r = np.linspace(ri, ro, nr + 1)
    t = np.linspace(0, 2 * np.pi, nt, endpoint=False)
    R, T = np.meshgrid(r, t, indexing="ij")
    p = np.stack([(R * np.cos(T)).ravel(), (R * np.sin(T)).ravel()], 1)
    idx = np.arange(p.shape[0]).reshape(nr + 1, nt)
    tri = []
    for i in range(nr):
        for j in range(nt):
            a, b, c, d = idx[i, j], idx[i, (j + 1) % nt], idx[i + 1, j], idx[i + 1, (j + 1) % nt]
            tri += [[a, b, d], [a, d, c]]
    return p, np.array(tri)


def _polygon_moments(p, t):
    """Exact area and polar moment of the straight-sided triangles."""
    x, y = p[t, 0], p[t, 1]
    A = 0.5 * np.abs((x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0]))
    sq = lambda v: (v ** 2).sum(1) + v[:, 0] * v[:, 1] + v[:, 0] * v[:, 2] + v[:, 1] * v[:, 2]  # noqa: E731
    return A, A / 6.0 * (sq(x) + sq(y))


def test_mass_matrix_of_annulus_equals_closed_form_with_thickness():
    """Consistent P2 mass: total mass and polar inertia of straight-sided triangles exactly; a per-triangle
    relative thickness scales its triangles' share."""
    p, t = _annulus(0.02, 0.07)
    A, Jp = _polygon_moments(p, t)
    fe = PlaneFE(p, t, MAT, lambda a, b: np.hypot(a[:, 0], a[:, 1]) < 0.0201, factorize=False)
    M = fe.mass_matrix(RHO)
    cx = fe.dof_component == 0
    X = fe.dof_locations
    rot = np.where(cx, -X[1], X[0])
    assert float(cx @ M @ cx) == pytest.approx(RHO * A.sum(), rel=1e-12)
    assert float(rot @ M @ rot) == pytest.approx(RHO * Jp.sum(), rel=1e-12)
    # closed form of the true annulus: the polygon is within its chord error (1 - cos(pi/48) ~ 0.2 %)
    assert float(cx @ M @ cx) == pytest.approx(RHO * np.pi * (0.07 ** 2 - 0.02 ** 2), rel=6e-3)
    th = np.where(np.hypot(*p[t].mean(1).T) < 0.045, 0.25, 1.0)
    fe2 = PlaneFE(p, t, MAT, lambda a, b: np.hypot(a[:, 0], a[:, 1]) < 0.0201, factorize=False, thickness=th)
    M2 = fe2.mass_matrix(RHO)
    assert float(cx @ M2 @ cx) == pytest.approx(RHO * (A * th).sum(), rel=1e-12)
    with pytest.raises(ModelError, match="density_kg_m3"):
        fe.mass_matrix(-1.0)


@pytest.fixture(scope="module")
def gear():
    return SyntheticGear(z=12, module_m=4e-3, bore_radius_m=8e-3)


@pytest.fixture(scope="module")
def body(gear):
    fc = gear_compliance(gear, MAT, "drive", options=COARSE, cache=False)
    bm = gear_body_modes(gear, MAT, RHO, fc, BodyModeOptions(max_frequency_Hz=60e3), cache=False)
    return fc, bm


def test_body_modes_sanity(gear, body):
    """Mass and inertia per unit width = density x area / polar moment of the gear outline (what the mesh
    covers); modes ascending and closing sense positive for the drive flank; participations bounded by the
    inertia (sum over all modes = rigid inertia, so a subset stays below)."""
    fc, bm = body
    assert bm.success and bm.n_modes >= 3
    # outline area of the whole gear: the tooth-sector boundary closed through the centre (shoelace), minus the bore
    xy = np.asarray(gear.tooth_boundary(120).xy)
    a_sector = 0.5 * np.sum(xy[:-1, 0] * xy[1:, 1] - xy[1:, 0] * xy[:-1, 1])
    area = gear.z * a_sector - np.pi * gear.bore_radius_m ** 2
    assert bm.mass_kg_per_m == pytest.approx(RHO * area, rel=2e-3)
    assert np.all(np.diff(bm.frequency_Hz) >= 0)
    assert bm.closing_sense == 1
    assert np.sum(bm.rotation_participation ** 2) < bm.inertia_kgm2_per_m
    # the h = 0 (rotation) modes carry the participation; degenerate pairs come complete
    counts = bm.complete_counts()
    assert counts[-1] == bm.n_modes
    assert bm.count_below(bm.frequency_Hz[0] * 1.0001) >= 1


def test_residual_compliance_is_positive_semidefinite(body):
    """sym(C_far) - sum_k phi phi^T / omega^2 over all teeth and samples: what stays quasi-static is a
    compliance (eigenvalues >= 0 up to the round-off of C itself), smaller than C."""
    fc, bm = body
    z, ns = fc.z, fc.n_samples
    C = np.zeros((z * ns, z * ns))
    for a in range(z):
        for b in range(z):
            C[a * ns:(a + 1) * ns, b * ns:(b + 1) * ns] = fc.far_field_m2_N[(b - a) % z]
    C = 0.5 * (C + C.T)
    P = bm.flank_normal.reshape(bm.n_modes, -1)
    R = C - (P / bm.omega_rad_s[:, None] ** 2).T @ P
    ev_c, ev_r = np.linalg.eigvalsh(C), np.linalg.eigvalsh(R)
    assert ev_c.min() > -1e-3 * ev_c.max()                 # C's own round-off level
    assert ev_r.min() > ev_c.min() - 1e-3 * ev_r.max()
    assert np.all(np.diag(R) < np.diag(C)) and np.all(np.diag(R) > 0)


@pytest.mark.slow
def test_first_body_mode_converges_with_mesh(gear, body):
    """The first fixed-hub frequency moves < 1 % when the mesh is refined 1.5x."""
    _, bm = body
    fine = COARSE.refined(1.5)
    fc2 = gear_compliance(gear, MAT, "drive", options=fine, cache=False)
    bm2 = gear_body_modes(gear, MAT, RHO, fc2, BodyModeOptions(max_frequency_Hz=bm.frequency_Hz[0] * 1.01),
                          cache=False)
    assert bm2.frequency_Hz[0] == pytest.approx(bm.frequency_Hz[0], rel=1e-2)


def test_options_validation():
    with pytest.raises(ModelError, match="max_frequency_Hz"):
        BodyModeOptions(max_frequency_Hz=1.0)
    with pytest.raises(ModelError, match="max_modes"):
        BodyModeOptions(max_modes=0)

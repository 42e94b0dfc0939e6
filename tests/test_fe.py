"""Tests of the finite-element far field (hacgear_core.statics.fe) and the analytical near field
(hacgear_core.statics.nearfield): closed forms, convergence, equilibrium, cyclic symmetry."""
from __future__ import annotations

import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(__file__))
from _fe_synthetic_gear import SyntheticGear  # noqa: E402

from hacgear_core.errors import GeometryError, ModelError  # noqa: E402
from hacgear_core.statics import fe as fe_module  # noqa: E402
from hacgear_core.statics.fe import (CyclicGearFE, ElasticMaterial, FlankCompliance, Gauge, GearFE, MeshOptions, PlaneFE,  # noqa: E402
                             build_gear_fe, gear_compliance, mesh_gear, rotation)
from hacgear_core.statics.nearfield import (effective_modulus, halfspace_approach_hertz,  # noqa: E402
                                    halfspace_approach_point, halfspace_strip_kernel, hertz_line_contact)

E, NU = 2.0e11, 0.3
MAT = ElasticMaterial(E, NU)
COARSE = MeshOptions(flank_size_m=0.6e-3, fillet_size_m=0.6e-3, body_size_m=3e-3)


@pytest.fixture(scope="module")
def gear():
    return SyntheticGear()


@pytest.fixture(scope="module")
def gear_fe(gear):
    """Reference whole-gear model (replicated mesh, one factorisation)."""
    return build_gear_fe(gear, MAT, COARSE, method="full")


@pytest.fixture(scope="module")
def gear_cyclic(gear):
    return build_gear_fe(gear, MAT, COARSE)


GAUGES = [Gauge("root_drive", "drive", 36.6e-3), Gauge("root_coast", "coast", 36.6e-3)]


@pytest.fixture(scope="module")
def flank(gear, gear_cyclic):
    return gear_compliance(gear, MAT, "drive", options=COARSE, fe=gear_cyclic, gauges=GAUGES, cache=False)


def test_cyclic_solver_equals_whole_gear_model(gear, gear_fe, gear_cyclic, flank):
    """The harmonic (cyclic-symmetry) solution equals the whole-gear solve on the
    replicated mesh: displacements on all teeth, gauge strains, hub forces."""
    assert isinstance(gear_cyclic, CyclicGearFE) and isinstance(gear_fe, GearFE)
    assert gear_cyclic.n_free == gear_fe.n_free and gear_cyclic.n_dofs == gear_fe.n_dofs
    full = gear_compliance(gear, MAT, "drive", options=COARSE, fe=gear_fe, gauges=GAUGES, cache=False)
    scale = np.abs(full.far_field_m2_N).max()
    assert np.abs(full.far_field_m2_N - flank.far_field_m2_N).max() < 1e-9 * scale
    np.testing.assert_allclose(flank.strain_per_N_m, full.strain_per_N_m, rtol=1e-8,
                               atol=1e-9 * np.abs(full.strain_per_N_m).max())
    np.testing.assert_allclose(flank.hub_force_per_N_m, full.hub_force_per_N_m, atol=1e-9)


# ----------------------------------------------------------------------------- near field closed forms
def test_hertz_closed_form_matches_discrete_halfspace_contact():
    """Two cylinders pressed together, solved as a discretised elastic half-space contact
    with the strip kernel: peak pressure and half-width within 1% of Hertz."""
    R1, R2, w = 20e-3, 30e-3, 2.0e5
    hz = hertz_line_contact(w, R1, R2, E, NU)
    a = hz.half_width_m
    n = 500
    x = np.linspace(-1.4 * a, 1.4 * a, n)
    h = 0.5 * (x[1] - x[0])
    K = 2 * halfspace_strip_kernel(x, x, h, E, NU)          # both bodies, same material
    g0 = x**2 / (2 * hz.effective_radius_m)
    active = np.abs(x) < 0.5 * a
    for _ in range(100):
        idx = np.flatnonzero(active)
        m = idx.size
        A = np.zeros((m + 1, m + 1))
        A[:m, :m] = K[np.ix_(idx, idx)]
        A[:m, m] = -1.0
        A[m, :m] = 2 * h
        sol = np.linalg.solve(A, np.r_[-g0[idx], w])
        p = np.zeros(n)
        p[idx] = sol[:m]
        gap = K @ p + g0 - sol[m]
        new = (p > 0) | (gap < 0)
        new[idx[p[idx] <= 0]] = False
        if np.array_equal(new, active):
            break
        active = new
    assert np.all(p >= 0) and np.all(gap[~active] >= -1e-12)
    inner = np.flatnonzero(p > 0)[3:-3]
    B, A0 = np.polyfit(x[inner] ** 2, p[inner] ** 2, 1)       # p^2 = p0^2 (1 - x^2/a^2)
    p0_num, a_num = np.sqrt(A0), np.sqrt(-A0 / B)
    assert abs(p0_num / hz.peak_pressure_Pa - 1) < 0.01
    assert abs(a_num / a - 1) < 0.01
    assert abs(p.max() / hz.peak_pressure_Pa - 1) < 0.01
    # consistency of the closed forms
    assert np.isclose(hz.peak_pressure_Pa, 2 * w / (np.pi * a))
    assert np.isclose(hz.effective_modulus_Pa, effective_modulus(E, NU, E, NU))
    assert np.isclose(effective_modulus(E, NU, E, NU, "strain"), E / (2 * (1 - NU**2)))


@pytest.mark.parametrize("plane", ["stress", "strain"])
def test_hertz_depth_approach_equals_superposed_point_loads(plane):
    """The Hertz depth approach (closed form) equals the superposition of the Flamant
    point-load approach over the Hertz pressure, at small and large d/a."""
    w, a = 1.0e5, 0.2e-3
    hz_p0 = 2 * w / (np.pi * a)
    n = 40000
    xi = (np.arange(n) + 0.5) / n * 2 * a - a
    p = hz_p0 * np.sqrt(1 - (xi / a) ** 2)
    dx = 2 * a / n
    for d in (0.1e-3, 1e-3, 10e-3):
        num = np.sum(p * dx * halfspace_approach_point(1.0, xi, d, E, NU, plane))
        ref = float(halfspace_approach_hertz(w, a, d, E, NU, plane))
        assert abs(num / ref - 1) < 2e-3, (d, num, ref)
    # d >> a: the textbook logarithmic form (difference O(a^2/d^2))
    d = 10e-3
    Ep = E if plane == "stress" else E / (1 - NU**2)
    nuq = NU if plane == "stress" else NU / (1 - NU)
    approx = 2 * w / (np.pi * Ep) * (np.log(2 * d / a) - nuq / 2)
    assert abs(float(halfspace_approach_hertz(w, a, d, E, NU, plane)) / approx - 1) < 2e-4


def test_nearfield_input_errors():
    with pytest.raises(ModelError, match="load_per_width_N_m"):
        hertz_line_contact(-1.0, 0.02, 0.02, E, NU)
    with pytest.raises(ModelError, match="combined curvature"):
        hertz_line_contact(1.0, 0.02, -0.02, E, NU)
    with pytest.raises(ModelError, match="poisson_ratio"):
        halfspace_approach_hertz(1.0, 1e-4, 1e-3, E, 0.6)
    with pytest.raises(ModelError, match="plane"):
        effective_modulus(E, NU, E, NU, "axisymmetric")


def test_resolved_fe_hertz_block_matches_halfspace_approach():
    """A large block loaded by a Hertz pressure, meshed finely under the load: the FE
    approach between surface centre and depth d matches the closed form within 1%."""
    import gmsh

    W, D, a, w = 60e-3, 30e-3, 0.2e-3, 1.0e5
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        geo = gmsh.model.geo
        pts = [geo.addPoint(x, y, 0) for x, y in ((-W / 2, -D), (W / 2, -D), (W / 2, 0), (0, 0), (-W / 2, 0))]
        lines = [geo.addLine(pts[i], pts[(i + 1) % 5]) for i in range(5)]
        geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        f = gmsh.model.mesh.field
        fd = f.add("Distance")
        f.setNumbers(fd, "PointsList", [pts[3]])
        ft = f.add("MathEval")
        f.setString(ft, "F", f"min({a / 12} + 0.12*F{fd}, 2e-3)")
        f.setAsBackgroundMesh(ft)
        for opt in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
            gmsh.option.setNumber(opt, 0)
        gmsh.model.mesh.generate(2)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        _, en = gmsh.model.mesh.getElementsByType(2)
    finally:
        gmsh.finalize()
    lut = np.zeros(int(tags.max()) + 1, int)
    lut[tags.astype(int)] = np.arange(len(tags))
    P = xyz.reshape(-1, 3)[:, :2]
    T = lut[en.astype(int).reshape(-1, 3)]
    used = np.unique(T)
    remap = np.zeros(len(P), int)
    remap[used] = np.arange(len(used))
    fe = PlaneFE(P[used], remap[T], MAT, lambda x0, x1: (np.abs(x0[:, 1] + D) < 1e-12) & (np.abs(x1[:, 1] + D) < 1e-12))
    nq = 2000
    xq = (np.arange(nq) + 0.5) / nq * 2 * a - a
    pq = 2 * w / (np.pi * a) * np.sqrt(1 - (xq / a) ** 2) * (2 * a / nq)
    F = fe.point_loads(np.stack([xq, np.zeros(nq)], 1), np.stack([np.zeros(nq), -pq], 1)).sum(axis=1)
    U = fe.solve(F)
    for d in (0.5e-3, 1.5e-3):
        Op = fe.displacement_operator(np.array([[0.0, 0.0], [0.0, -d]]))
        uy = (Op @ U)[1::2]
        fe_approach = uy[1] - uy[0]
        ref = float(halfspace_approach_hertz(w, a, d, E, NU))
        assert abs(fe_approach / ref - 1) < 0.01, (d, fe_approach, ref)


# ----------------------------------------------------------------------------- plane FE basics
def _cantilever(nx, ny, L=0.1, c=5e-3, P=1.0e4):
    from skfem import MeshTri

    m = MeshTri.init_tensor(np.linspace(0, L, nx + 1), np.linspace(-c, c, ny + 1))
    I = 2 * c**3 / 3
    G = E / (2 * (1 + NU))

    def exact(x, y):   # Timoshenko & Goodier: end load P at x = 0, built in at x = L
        u = (-P * x**2 * y / (2 * E * I) - NU * P * y**3 / (6 * E * I) + P * y**3 / (6 * I * G)
             + (P * L**2 / (2 * E * I) - P * c**2 / (2 * I * G)) * y)
        v = NU * P * x * y**2 / (2 * E * I) + P * x**3 / (6 * E * I) - P * L**2 * x / (2 * E * I) + P * L**3 / (3 * E * I)
        return u, v

    fe = PlaneFE(m.p.T, m.t.T, MAT, lambda x0, x1: (np.abs(x0[:, 0] - L) < 1e-12) & (np.abs(x1[:, 0] - L) < 1e-12))
    ux, uy = exact(*fe.dof_locations)
    Ufix = np.where(fe.dof_component == 0, ux, uy)
    # parabolic shear traction on x = 0, 3-point Gauss per edge
    yk = np.linspace(-c, c, ny + 1)
    gp, gw = np.polynomial.legendre.leggauss(3)
    ys = (0.5 * (yk[1:] + yk[:-1])[:, None] + 0.5 * np.diff(yk)[:, None] * gp).ravel()
    ws = (0.5 * np.diff(yk)[:, None] * gw).ravel()
    ty = P / (2 * I) * (c**2 - ys**2) * ws
    F = fe.point_loads(np.stack([np.zeros_like(ys), ys], 1), np.stack([np.zeros_like(ys), ty], 1)).sum(axis=1)
    U = fe.solve(F, U_fixed=Ufix)
    tip = (fe.displacement_operator(np.array([[0.0, 0.0]])) @ U)[1]
    return tip, P * L**3 / (3 * E * I), fe, U


def test_cantilever_tip_deflection_and_p2_convergence():
    """Plane-stress cantilever strip against the exact elasticity (Timoshenko & Goodier)
    solution, whose tip deflection is P L^3/(3 E I); the P2 error falls fast with h."""
    errs = []
    for nx, ny in ((10, 1), (20, 2), (40, 4)):
        tip, ref, fe, U = _cantilever(nx, ny)
        errs.append(abs(tip / ref - 1))
    assert errs[-1] < 1e-3
    assert errs[1] < errs[0] / 3 and errs[2] < errs[1] / 3
    # Timoshenko beam theory (shear-corrected) with the same built-in end is within 2%
    L, c = 0.1, 5e-3
    G = E / (2 * (1 + NU))
    timo = 1.0e4 * L**3 / (3 * E * 2 * c**3 / 3) + 1.0e4 * L / (5 / 6 * G * 2 * c)
    assert abs(tip / timo - 1) < 0.02


def test_surface_strain_operator_on_cantilever():
    """Bending strain at the top surface of the cantilever: eps_xx = -P x c/(E I)."""
    L, c, P = 0.1, 5e-3, 1.0e4
    I = 2 * c**3 / 3
    x = np.array([0.31 * L, 0.63 * L])
    errs = []
    for nx, ny in ((20, 2), (40, 4), (80, 8)):
        tip, ref, fe, U = _cantilever(nx, ny)
        S = fe.strain_operator(np.stack([x, np.full(2, c)], 1), np.array([[1.0, 0.0], [-1.0, 0.0]])) @ U
        errs.append(np.abs(S / (-P * x * c / (E * I)) - 1).max())
    assert errs[-1] < 2e-3
    assert errs[2] < errs[1] < errs[0]


# ----------------------------------------------------------------------------- gear model
def test_gear_mesh_is_cyclic_and_conforming(gear, gear_fe):
    gm = gear_fe.gear_mesh
    assert gm.t.shape[0] == gear.z * gm.n_sector_triangles
    # rotating the node set by one pitch maps it onto itself
    from scipy.spatial import cKDTree

    Pr = gm.p @ rotation(2 * np.pi / gear.z).T
    dist, _ = cKDTree(gm.p).query(Pr)
    assert dist.max() < 1e-9
    # conforming: every interior edge is shared by exactly two triangles, boundary = outline + bore
    d = gm.p[gm.t]
    area2 = (d[:, 1, 0] - d[:, 0, 0]) * (d[:, 2, 1] - d[:, 0, 1]) - (d[:, 2, 0] - d[:, 0, 0]) * (d[:, 1, 1] - d[:, 0, 1])
    assert np.all(area2 > 0)
    bf = gear_fe.mesh.boundary_facets()
    r = np.hypot(*gear_fe.mesh.p[:, gear_fe.mesh.facets[:, bf]].mean(axis=1))
    assert np.all((r > gear.root_radius_m - 1e-5) | (np.abs(r - gear.bore_radius_m) < 1e-4))


def test_hub_reactions_balance_unit_loads(gear, gear_fe, flank):
    """Force and moment on the hub equal the applied unit loads (equilibrium)."""
    F_applied = -flank.normal
    M_applied = flank.xy_m[:, 0] * F_applied[:, 1] - flank.xy_m[:, 1] * F_applied[:, 0]
    np.testing.assert_allclose(flank.hub_force_per_N_m[:, :2], F_applied, atol=1e-8)
    # (load points on the true flank are snapped onto the mesh polygon: ~1 um, hence rtol 1e-4)
    np.testing.assert_allclose(flank.hub_force_per_N_m[:, 2], M_applied, rtol=1e-4)
    # a load on tooth 4 gives the rotated hub force
    k, i = 4, 7
    R = rotation(2 * np.pi * k / gear.z)
    F = gear_fe.point_loads((flank.xy_m[i] @ R.T)[None], (-flank.normal[i] @ R.T)[None])
    H = gear_fe.hub_force(gear_fe.solve(F), F)[0]
    np.testing.assert_allclose(H, flank.hub_force(k, flank.s_m[i]), atol=1e-9)


def test_cyclic_symmetry_direct_load_on_tooth_3(gear, gear_fe, flank):
    """Load applied directly on tooth 3, response read on teeth 2..6 equals the tooth-0
    influence at offsets -1..3 (rotated), displacements and gauge strains."""
    z, m = gear.z, 3
    R = rotation(2 * np.pi * m / z)
    i = flank.n_samples // 2
    F = gear_fe.point_loads((flank.xy_m[i] @ R.T)[None], (-flank.normal[i] @ R.T)[None])
    U = gear_fe.solve(F)[:, 0]
    read = flank.xy_m - flank.depth_m[:, None] * flank.normal
    for k in range(m - 1, m + 4):
        Rk = rotation(2 * np.pi * k / z)
        D = (gear_fe.displacement_operator(read @ Rk.T) @ U).reshape(-1, 2)
        c_direct = np.einsum("jc,jc->j", D, -flank.normal @ Rk.T)
        np.testing.assert_allclose(c_direct, flank.far_field_m2_N[(k - m) % z, i], rtol=1e-6,
                                   atol=1e-9 * flank.far_field_m2_N[0, i, i])
        q = (flank.gauge_xy_m[0] - 2e-6 * np.array([flank.gauge_tangent[0, 1], -flank.gauge_tangent[0, 0]])) @ Rk.T
        s_direct = gear_fe.strain_operator(q[None], (flank.gauge_tangent[0] @ Rk.T)[None]) @ U
        assert np.isclose(s_direct[0], flank.strain(0, k - m, flank.s_m[i]), rtol=1e-3,
                          atol=1e-3 * abs(flank.strain_per_N_m[0, 0, i]))


def test_flank_compliance_physics(gear, flank):
    """Own-tooth compliance grows towards the tip, neighbours couple less than the tooth
    itself, and the loaded-side root is in tension (opposite side in compression)."""
    C = flank.far_field_m2_N
    diag = np.array([C[0, i, i] for i in range(flank.n_samples)])
    inv = np.flatnonzero(flank.region == 2)
    assert np.all(np.diff(diag[inv]) < 0)                 # s grows towards the root: stiffer
    assert np.all(C[1][np.ix_(inv, inv)] < C[0][np.ix_(inv, inv)])
    assert np.all(C[-1][np.ix_(inv, inv)] < C[0][np.ix_(inv, inv)])
    mid = inv[len(inv) // 2]
    assert 0.05 < C[1, mid, mid] / C[0, mid, mid] < 0.6
    assert np.all(flank.strain_per_N_m[0, 0, inv] > 0)    # drive root, load on drive flank
    assert np.all(flank.strain_per_N_m[1, 0, inv] < 0)    # coast root
    # gauge lies on the requested radius on the correct side
    assert np.isclose(np.hypot(*flank.gauge_xy_m[0]), 36.6e-3, rtol=1e-4)
    assert flank.gauge_xy_m[0, 1] > 0 > flank.gauge_xy_m[1, 1]


def test_interpolation_reproduces_samples_and_is_linear(flank):
    s = flank.s_m
    assert np.isclose(flank.far_field(2, s[4], s[9]), flank.far_field_m2_N[2, 4, 9])
    mid = 0.5 * (s[4] + s[5])
    assert np.isclose(flank.far_field(0, mid, mid),
                      0.25 * flank.far_field_m2_N[0, 4:6, 4:6].sum())
    # mutual near-field term on the same tooth decays with distance and is absent on others
    c0 = flank.compliance(0, s[4], s[12])
    assert c0 != flank.far_field(0, s[4], s[12])
    assert flank.compliance(1, s[4], s[12]) == flank.far_field(1, s[4], s[12])
    M = flank.matrix()
    assert np.isclose(M[0, 4, 12], c0) and np.isclose(M[0, 4, 4], flank.far_field_m2_N[0, 4, 4])
    with pytest.raises(GeometryError, match="profile coordinate"):
        flank.far_field(0, s[-1] + 1e-3, s[0])


def test_nearfield_corrected_compliance_independent_of_depth(gear, gear_fe):
    """Far field read at depth d plus the half-space term does not depend on d (within 1%)."""
    w = 1.0e5
    vals, vals_far = [], []
    for d in (0.5e-3, 1.0e-3, 1.5e-3):
        fc = gear_compliance(gear, MAT, "drive", options=COARSE, fe=gear_fe, depth_m=d, cache=False)
        s = 0.5 * (fc.s_m[0] + fc.s_m[-1])
        R = float(np.interp(s, fc.s_m, fc.curvature_radius_m))
        a = hertz_line_contact(w, R, R, E, NU).half_width_m
        vals.append(fc.far_field(0, s, s) + fc.self_approach(w, a, s) / w)
        vals_far.append(fc.far_field(0, s, s))      # the uncorrected far field does depend on d
    assert max(vals) / min(vals) - 1 < 0.01
    assert max(vals_far) / min(vals_far) - 1 > 0.02


def _corrected(fc, w=1.0e5):
    out = []
    for s in (fc.s_m[3], 0.5 * (fc.s_m[0] + fc.s_m[-1]), fc.s_m[-6]):
        R = float(np.interp(s, fc.s_m, fc.curvature_radius_m))
        a = hertz_line_contact(w, R, R, E, NU).half_width_m
        out.append(float(fc.far_field(0, s, s) + fc.self_approach(w, a, s) / w))
    return np.array(out)


def _refinement_study(gear, base):
    return [_corrected(gear_compliance(gear, MAT, "drive", options=base.refined(f), cache=False, depth_m=1.0e-3))
            for f in (1, 2, 4)]


def test_mesh_refinement_changes_flank_compliance_below_1_percent(gear):
    """Halving every element size twice (0.6 -> 0.3 -> 0.15 mm on the flanks, up to
    ~450k equivalent DOF) changes the near-field-corrected compliance at flank points (tip
    side, mid flank, root side) by less than 1% per step and in total; from a coarse
    1.2 mm mesh as well."""
    for base in (COARSE, COARSE.refined(0.5)):
        vals = _refinement_study(gear, base)
        assert np.all(np.abs(vals[1] / vals[0] - 1) < 0.01)
        assert np.all(np.abs(vals[2] / vals[1] - 1) < 0.01)
        assert np.all(np.abs(vals[2] / vals[0] - 1) < 0.01)


def test_cache_roundtrip(gear, tmp_path, monkeypatch):
    monkeypatch.setenv("HACGEAR_CACHE_DIR", str(tmp_path))
    opts = MeshOptions(flank_size_m=1.5e-3, fillet_size_m=1.5e-3, body_size_m=6e-3)
    a = gear_compliance(gear, MAT, "coast", options=opts, gauges=[Gauge("g", "coast", 36.6e-3)])
    files = list((tmp_path / "fe").glob("flank_*.npz"))
    assert len(files) == 1
    # the second call reads the cache: it must not build the finite-element model again
    def no_build(*args, **kwargs):
        raise AssertionError("gear_compliance rebuilt the FE model although its cache entry exists")

    monkeypatch.setattr(fe_module, "build_gear_fe", no_build)
    b = gear_compliance(gear, MAT, "coast", options=opts, gauges=[Gauge("g", "coast", 36.6e-3)])
    monkeypatch.undo()
    monkeypatch.setenv("HACGEAR_CACHE_DIR", str(tmp_path))
    np.testing.assert_array_equal(a.far_field_m2_N, b.far_field_m2_N)
    np.testing.assert_array_equal(a.strain_per_N_m, b.strain_per_N_m)
    assert b.gauge_names == ("g",) and b.info["cache_key"] == a.info["cache_key"]
    # another material is another cache entry with stiffer results
    c = gear_compliance(gear, ElasticMaterial(2 * E, NU), "coast", options=opts, gauges=[Gauge("g", "coast", 36.6e-3)])
    assert len(list((tmp_path / "fe").glob("flank_*.npz"))) == 2
    np.testing.assert_allclose(c.far_field_m2_N, a.far_field_m2_N / 2, rtol=1e-6)
    assert isinstance(FlankCompliance.load(files[0]), FlankCompliance)


def test_input_validation(gear):
    with pytest.raises(ModelError, match="youngs_modulus_Pa"):
        ElasticMaterial(-1.0, 0.3)
    with pytest.raises(ModelError, match="poisson_ratio"):
        ElasticMaterial(2e11, 0.5)
    with pytest.raises(ModelError, match="flank_size_m"):
        MeshOptions(flank_size_m=0.0)
    with pytest.raises(ModelError, match="side"):
        gear_compliance(gear, MAT, "left")
    with pytest.raises(ModelError, match="depth_m"):
        gear_compliance(gear, MAT, "drive", depth_m=1.0)
    with pytest.raises(ModelError, match="Gauge.side"):
        Gauge("x", "up", 0.03)
    with pytest.raises(GeometryError, match="radius_m"):
        gear_compliance(gear, MAT, "drive", options=COARSE, gauges=[Gauge("x", "drive", 0.5)], cache=False)
    bad = SyntheticGear(bore_radius_m=40e-3)
    with pytest.raises(GeometryError, match="bore_radius_m"):
        mesh_gear(bad, COARSE)


def test_reciprocity_between_teeth(flank):
    """Maxwell-Betti: the influence of tooth 0 on tooth k equals (transposed) that of tooth
    k on tooth 0, i.e. C[k] = C[-k]^T, up to the depth reading (< 1%)."""
    inv = np.flatnonzero(flank.region == 2)
    M = flank.matrix()
    for k in (1, 2, 3):
        A = M[k][np.ix_(inv, inv)]
        B = M[-k].T[np.ix_(inv, inv)]
        assert np.abs(A / B - 1).max() < 0.01


def _real_gear(system="spur_28t_asym", index=0):
    geometry = pytest.importorskip("hacgear_core.geometry")
    from hacgear_core.kinds import load_model

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    model = load_model(os.path.join(root, "models", system, "model.toml"))
    g = model.gears[index]
    return g, geometry.gear_geometry(g)


def test_real_28t_gear_mesh_is_periodic():
    gear, gg = _real_gear()
    gm = mesh_gear(gg, MeshOptions(flank_size_m=1.0e-3, fillet_size_m=1.0e-3, body_size_m=4e-3))
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(gm.p).query(gm.p @ rotation(2 * np.pi / gg.z).T)
    assert dist.max() < 1e-9
    r = np.hypot(gm.p[:, 0], gm.p[:, 1])
    assert np.isclose(r.min(), gg.bore_radius_m, rtol=1e-9)
    assert r.max() <= gg.tip_radius_m * (1 + 1e-9) and r.max() > gg.tip_radius_m * (1 - 1e-3)   # tip relief lowers the corner
    assert gm.t.shape[0] == gg.z * gm.n_sector_triangles


def test_real_28t_gear_compliance():
    """28-tooth asymmetric gear (dissertation Table 3.3), default mesh: identical-pair
    stiffness at the pitch point (plane stress, 15 mm, no crowning), neighbour coupling,
    gauges in the fillet with tension on the loaded side, equilibrium."""
    gear, gg = _real_gear()
    mat = ElasticMaterial(gear.material.youngs_modulus_Pa, gear.material.poisson_ratio)
    gauges = [Gauge(x.name, x.flank, x.radius_m) for x in gear.gauges]
    fc = gear_compliance(gg, mat, "drive", gauges=gauges, cache=False)
    r = np.hypot(fc.xy_m[:, 0], fc.xy_m[:, 1])
    s_p = float(np.interp(gg.pitch_radius_m, r[::-1], fc.s_m[::-1]))
    w = 300.0 / (gg.base_radius_m["drive"] * gear.face_width_m)
    rho = float(np.interp(s_p, fc.s_m, fc.curvature_radius_m))
    a = hertz_line_contact(w, rho, rho, mat.youngs_modulus_Pa, mat.poisson_ratio).half_width_m
    c_tooth = fc.far_field(0, s_p, s_p) + fc.self_approach(w, a, s_p) / w
    k_pair = gear.face_width_m / (2 * c_tooth)
    assert 1.4e8 < k_pair < 1.8e8
    assert 0.25 < fc.far_field(1, s_p, s_p) / fc.far_field(0, s_p, s_p) < 0.5
    assert [g["region"] for g in fc.info["gauges"]] == [1, 1]
    assert fc.strain("SG25", 0, s_p) > 0 > fc.strain("SG20", 0, s_p)
    F = -fc.normal
    np.testing.assert_allclose(fc.hub_force_per_N_m[:, :2], F, atol=1e-8)


@pytest.mark.slow
def test_real_28t_gear_refinement():
    """28-tooth gear: identical-pair pitch-point compliance and gauge strains change by
    less than 1% when the default mesh is refined twice."""
    gear, gg = _real_gear()
    mat = ElasticMaterial(gear.material.youngs_modulus_Pa, gear.material.poisson_ratio)
    w = 300.0 / (gg.base_radius_m["drive"] * gear.face_width_m)
    out = []
    for f in (1, 2, 4):
        fc = gear_compliance(gg, mat, "drive", options=MeshOptions().refined(f), gauges=gear.gauges, cache=False)
        r = np.hypot(fc.xy_m[:, 0], fc.xy_m[:, 1])
        s_p = float(np.interp(gg.pitch_radius_m, r[::-1], fc.s_m[::-1]))
        rho = float(np.interp(s_p, fc.s_m, fc.curvature_radius_m))
        a = hertz_line_contact(w, rho, rho, mat.youngs_modulus_Pa, mat.poisson_ratio).half_width_m
        out.append([fc.far_field(0, s_p, s_p) + fc.self_approach(w, a, s_p) / w,
                    fc.far_field(1, s_p, s_p), fc.strain(0, 0, s_p), fc.strain(1, 0, s_p)])
    out = np.array(out)
    assert np.all(np.abs(out[1] / out[0] - 1) < 0.01)
    assert np.all(np.abs(out[2] / out[1] - 1) < 0.01)


def test_internal_ring_gear_compliance():
    """Internal gear (175-tooth ring of the planetary model, rim tied to the hub): the
    cyclic solve gives positive own-tooth compliance, smaller neighbour coupling, and hub
    reactions that balance the unit loads."""
    ring, gg = _real_gear("planetary_65_55_175", 2)
    assert gg.internal
    fc = gear_compliance(gg, ring.material, "drive", cache=False,
                         options=MeshOptions(flank_size_m=1.0e-3, fillet_size_m=1.0e-3, body_size_m=4e-3))
    inv = np.flatnonzero(fc.region == 2)
    d0 = np.array([fc.far_field_m2_N[0, i, i] for i in inv])
    d1 = np.array([fc.far_field_m2_N[1, i, i] for i in inv])
    assert np.all(d0 > 0) and np.all(np.abs(d1) < 0.5 * d0)
    F = -fc.normal
    np.testing.assert_allclose(fc.hub_force_per_N_m[:, :2], F, atol=1e-8)
    M = fc.xy_m[:, 0] * F[:, 1] - fc.xy_m[:, 1] * F[:, 0]
    np.testing.assert_allclose(fc.hub_force_per_N_m[:, 2], M, rtol=1e-4)


def test_sector_cut_angle_does_not_change_the_physics():
    """The cyclic sector may be cut anywhere in the root land (``sector_offset_rad``, used when the
    land lies off the mid-space angle): compliances and gauge strains of the 28-tooth gear agree
    within the discretisation error (0.5 %), and the cache key follows the cut."""
    import dataclasses

    gear, gg = _real_gear()
    mat = ElasticMaterial(gear.material.youngs_modulus_Pa, gear.material.poisson_ratio)
    gauges = [Gauge(x.name, x.flank, x.radius_m) for x in gear.gauges]
    out = []
    for off in (0.0, 0.005, -0.004):   # the land spans about -0.0087..+0.0087 rad around pi/z
        g2 = dataclasses.replace(gg, sector_offset_rad=off, _cache={})
        a0 = np.arctan2(*g2.tooth_boundary(100).xy[0][::-1])
        assert a0 == pytest.approx(-np.pi / gg.z + off, abs=1e-9)
        fc = gear_compliance(g2, mat, "drive", gauges=gauges, cache=False)
        r = np.hypot(fc.xy_m[:, 0], fc.xy_m[:, 1])
        s_p = float(np.interp(gg.pitch_radius_m, r[::-1], fc.s_m[::-1]))
        out.append((np.array([fc.far_field(0, s_p, s_p), fc.far_field(1, s_p, s_p), fc.strain("SG25", 0, s_p),
                              fc.strain("SG20", 0, s_p)]), fc.info["cache_key"]))
    for v, _ in out[1:]:
        np.testing.assert_allclose(v, out[0][0], rtol=5e-3)
    assert len({k for _, k in out}) == 3


def test_full_round_fillet_gear_mesh_is_periodic():
    """Hob tip radius 1.8 mm (dissertation Fig. 2.7b): the root land lies off the mid-space angle;
    the sector is cut in it and the replicated mesh is still periodic and conforming."""
    import dataclasses

    geometry = pytest.importorskip("hacgear_core.geometry")
    gear, _ = _real_gear()
    gg = geometry.gear_geometry(dataclasses.replace(gear, hob_tip_radius_m=1.8e-3))
    assert gg.sector_offset_rad > 0
    gm = mesh_gear(gg, MeshOptions(flank_size_m=1.0e-3, fillet_size_m=1.0e-3, body_size_m=4e-3))
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(gm.p).query(gm.p @ rotation(2 * np.pi / gg.z).T)
    assert dist.max() < 1e-9
    assert gm.sector_offset_rad == gg.sector_offset_rad
    assert np.hypot(gm.p[:, 0], gm.p[:, 1]).max() <= gg.tip_radius_m * (1 + 1e-9)


# ----------------------------------------------------------------------------- webbed blanks
WEB_RI, WEB_RO = 20e-3, 30e-3          # synthetic gear: bore 15 mm, root 35 mm


def _webbed_synthetic(rel_thickness):
    """The synthetic gear with a web from r = 20 to 30 mm of relative thickness t/b (None: solid)."""
    from hacgear_core.geometry import WebGeometry

    g = SyntheticGear()
    if rel_thickness is not None:
        g.web = WebGeometry(rel_thickness * g.face_width_m, WEB_RI, WEB_RO, rel_thickness)
    return g


def _torsional_compliance(fe, g):
    """Rotation per unit torque [rad per N m/m] of the rim relative to the hub: tangential unit loads
    at the same rim point of every tooth (the sum over teeth of the tooth-0 influence: a pure torque,
    no net force), read tangentially at that point and divided by its radius."""
    R = 0.5 * (WEB_RO + g.root_radius_m)
    p, d = np.array([[R, 0.0]]), np.array([[0.0, 1.0]])
    disp, _, hub = fe.influence(p, d, p, d, np.zeros((0, 2)), np.zeros((0, 2)))
    torque = g.z * hub[0, 2]
    assert torque == pytest.approx(g.z * R, rel=1e-9)          # equilibrium: the hub carries the torque
    return disp[:, 0, 0].sum() / R / torque


def test_web_mesh_conforms_to_web_circles():
    """The sector mesh has element edges on both web circles (no triangle straddles one), stays periodic,
    and the web triangles (by gmsh surface) are exactly those whose centroid lies between the circles."""
    from scipy.spatial import cKDTree

    g = _webbed_synthetic(0.3)
    gm = mesh_gear(g, COARSE)
    assert gm.web_radii_m == (WEB_RI, WEB_RO)
    dist, _ = cKDTree(gm.p).query(gm.p @ rotation(2 * np.pi / g.z).T)
    assert dist.max() < 1e-9
    r_node = np.hypot(gm.sector_p[:, 0], gm.sector_p[:, 1])
    r_tri = r_node[gm.sector_t]
    for rc in (WEB_RI, WEB_RO):
        on = np.abs(r_node - rc) < 1e-9 * rc
        assert on.sum() >= 4                                   # nodes on the arc, including both cut ends
        tol = 1e-9 * rc
        assert np.all((r_tri.max(axis=1) <= rc + tol) | (r_tri.min(axis=1) >= rc - tol))
    cen = np.hypot(*gm.sector_p[gm.sector_t].mean(axis=1).T)
    in_web = (cen > WEB_RI) & (cen < WEB_RO)
    np.testing.assert_array_equal(gm.sector_thickness, np.where(in_web, 0.3, 1.0))
    assert gm.thickness.shape == (gm.t.shape[0],) and np.all(gm.thickness.reshape(g.z, -1) == gm.sector_thickness)
    # solid blank: no labels, no web circles
    gs = mesh_gear(SyntheticGear(), COARSE)
    assert gs.sector_thickness is None and gs.thickness is None and gs.web_radii_m is None
    # web radii outside (bore, root) are refused
    bad = _webbed_synthetic(0.3)
    bad.web = type(bad.web)(3e-3, WEB_RI, 36e-3, 0.3)
    with pytest.raises(GeometryError, match="web radii"):
        mesh_gear(bad, COARSE)


def test_web_torsion_matches_thin_annulus_closed_form():
    """Hub-to-rim torsional compliance of an annulus r_h..r_r of thickness t: (1/r_h^2 - 1/r_r^2)/(4 pi G t).
    Changing only the web thickness changes the gear's torsional compliance by exactly that amount
    (rim, hub and teeth unchanged); the FE per unit face width has t = relative thickness.  Cyclic and
    full-gear solvers agree; the web at full thickness equals the solid blank."""
    G = E / (2 * (1 + NU))
    c = {}
    for f in (None, 1.0, 0.5, 0.1):
        c[f] = _torsional_compliance(build_gear_fe(_webbed_synthetic(f), MAT, COARSE), _webbed_synthetic(f))
    full = _torsional_compliance(build_gear_fe(_webbed_synthetic(0.1), MAT, COARSE, method="full"),
                                 _webbed_synthetic(0.1))
    assert full == pytest.approx(c[0.1], rel=1e-9)
    assert c[1.0] == pytest.approx(c[None], rel=5e-3)
    for f1, f2 in ((1.0, 0.5), (1.0, 0.1), (0.5, 0.1)):
        pred = (1 / WEB_RI ** 2 - 1 / WEB_RO ** 2) / (4 * np.pi * G) * (1 / f2 - 1 / f1)
        assert (c[f2] - c[f1]) / pred == pytest.approx(1.0, abs=0.02)


def test_web_at_full_thickness_equals_solid_blank():
    """A web as thick as the face width is the solid blank: flank compliances (all teeth), gauge strains
    and hub forces agree within mesh noise (< 0.5 %); the cache key differs only when a web is present."""
    res = {}
    for f in (None, 1.0, 0.3):
        fc = gear_compliance(_webbed_synthetic(f), MAT, "drive", options=COARSE, gauges=GAUGES, cache=False)
        res[f] = fc
    a, b, thin = res[None], res[1.0], res[0.3]
    scale = np.abs(a.far_field_m2_N).max()
    assert np.abs(b.far_field_m2_N - a.far_field_m2_N).max() < 5e-3 * scale
    np.testing.assert_allclose(b.strain_per_N_m, a.strain_per_N_m, rtol=5e-3,
                               atol=5e-3 * np.abs(a.strain_per_N_m).max())
    np.testing.assert_allclose(b.hub_force_per_N_m[:, :2], -b.normal, atol=1e-8)        # equilibrium
    np.testing.assert_allclose(b.hub_force_per_N_m[:, 2], a.hub_force_per_N_m[:, 2], rtol=1e-4)
    # a thin web makes every tooth more compliant (the blank twists more)
    i = a.n_samples // 2
    assert np.all(thin.far_field_m2_N[:, i, i] > b.far_field_m2_N[:, i, i] - 1e-3 * scale)
    assert thin.far_field_m2_N[0, i, i] > 1.05 * b.far_field_m2_N[0, i, i]
    keys = {f: fc.info["cache_key"] for f, fc in res.items()}
    assert len(set(keys.values())) == 3
    g = SyntheticGear()
    g.web = None                       # an explicit None keeps the solid blank's key (old caches stay valid)
    assert gear_compliance(g, MAT, "drive", options=COARSE, gauges=GAUGES, cache=False).info["cache_key"] == keys[None]


def _model_with_web(thickness_mm, inner_mm=60.0, outer_mm=110.0):
    from pathlib import Path

    from hacgear_core.kinds import parse_model

    root = Path(__file__).resolve().parent.parent
    text = (root / "models" / "spur_28t_asym" / "model.toml").read_text()
    if thickness_mm is not None:
        text = text.replace('material = "steel"\n', f'material = "steel"\n  [gears.web]\n  thickness_mm = {thickness_mm}\n'
                            f'  inner_diameter_mm = {inner_mm}\n  outer_diameter_mm = {outer_mm}\n')
    return parse_model(text, file="spur_28t_webbed.toml")


def test_thinner_web_lowers_mesh_stiffness(tmp_path, monkeypatch):
    """28-tooth pair (both gears webbed, 60/110 mm): the mean mesh stiffness falls as the web thins,
    and a web as thick as the face width gives the solid blank's stiffness (within 0.5 %)."""
    contact = pytest.importorskip("hacgear_core.statics")
    from hacgear_core.geometry import mesh_geometry

    monkeypatch.setenv("HACGEAR_CACHE_DIR", str(tmp_path))   # the two identical gears share one FE solve
    k = {}
    for t in (None, 15.0, 5.0, 2.5):
        model = _model_with_web(t)
        solver = contact.make_mesh_solver(model, "m12")
        W = 300.0 / mesh_geometry(model, "m12").base_radius_m["pinion"]
        k[t] = contact.mesh_stiffness_curve(solver, W, positions=8).mean_mesh_stiffness_N_per_m
    assert k[15.0] == pytest.approx(k[None], rel=5e-3)
    assert k[None] > 1.15 * k[5.0] > 1.15 * 1.1 * k[2.5]


def test_root_gauge_is_a_free_surface_so_stress_is_E_times_strain():
    """The contact solver reports root stress at a gauge as E * (surface strain along the profile), which
    assumes a traction-free surface (plane stress).  Check it on the real 28-tooth gear with the FE's full
    strain tensor at the gauge point (strain along t, n and the diagonal) for a load at the pitch point:
    the normal and shear stresses vanish next to the tangential one, and sigma_t = E eps_t."""
    from hacgear_core.statics.fe import _gauge_location

    gear, gg = _real_gear()
    mat = ElasticMaterial(gear.material.youngs_modulus_Pa, gear.material.poisson_ratio)
    fe = build_gear_fe(gg, mat)
    prof = gg.flank("drive", 2000)
    xy, nrm, r = np.asarray(prof.xy), np.asarray(prof.normal), np.asarray(prof.radius)
    i = int(np.argmin(np.abs(r - gg.pitch_radius_m)))
    E, nu = mat.youngs_modulus_Pa, mat.poisson_ratio
    for g in gear.gauges:
        p, t, n, _, region = _gauge_location(gg, Gauge(g.name, g.flank, g.radius_m), 800)
        q = p - 2e-6 * n                        # the production reading point, 2 um below the surface
        d = (t + n) / np.sqrt(2.0)
        _, S, _ = fe.influence(xy[i:i + 1], -nrm[i:i + 1], np.zeros((0, 2)), np.zeros((0, 2)),
                               np.stack([q, q, q]), np.stack([t, n, d]))
        e_t, e_n, e_d = S[0, :, 0]
        e_tn = e_d - 0.5 * (e_t + e_n)          # tensor shear strain
        c = E / (1 - nu * nu)
        s_t, s_n, s_tn = c * (e_t + nu * e_n), c * (e_n + nu * e_t), E / (1 + nu) * e_tn
        assert abs(s_t) > 0
        assert abs(s_n) < 0.02 * abs(s_t) and abs(s_tn) < 0.02 * abs(s_t), (g.name, s_t, s_n, s_tn)
        assert s_t == pytest.approx(E * e_t, rel=0.01)

"""Any size (#51 item 2): finite-element and contact lengths that scale with the module (``[statics] fe_lengths``),
one FE build per gear before the statics workers, and ``hacgear statics --face-coupling``.

Bit-for-bit comparisons are made only within one run (the current code against a recomputation with explicit
absolute lengths); nothing recorded on a machine is compared."""
from __future__ import annotations

import textwrap
from dataclasses import replace

import numpy as np
import pytest

from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry
from hacgear_core.kinds import load_model
from hacgear_core.statics import fe as fe_mod
from hacgear_core.statics.contact import (ContactOptions, default_contact_options, make_mesh_solver,
                                          mesh_solver_inputs, prebuild_compliances)


def _iso_pair_toml(module_mm: float, statics: str = "") -> str:
    """An ISO 21771 form spur pair 28/33 of normal module ``module_mm`` (rack A, face width 10 m_n, bore 6 m_n)."""
    gear = textwrap.dedent(f"""\
        teeth = {{teeth}}
        normal_module_mm = {module_mm!r}
        normal_pressure_angle_deg = 20.0
        basic_rack = "A"
        face_width_mm = {10 * module_mm!r}
        bore_diameter_mm = {6 * module_mm!r}
        material = "steel"
        """)
    return textwrap.dedent("""\
        [system]
        name = "iso_pair"
        kind = "spur_pair"
        [materials.steel]
        density_kg_per_m3 = 7850.0
        youngs_modulus_GPa = 206.0
        poisson_ratio = 0.3
        """) + '[[gears]]\nname = "pinion"\n' + gear.format(teeth=28) + '[[gears]]\nname = "wheel"\n' + \
        gear.format(teeth=33) + textwrap.dedent("""\
        [[meshes]]
        name = "m"
        gear_a = "pinion"
        gear_b = "wheel"
        [damping]
        modal_damping_ratio = 0.02
        [operating]
        torque_Nm = 100.0
        """) + statics


def _iso_model(tmp_path, module_mm: float, statics: str = ""):
    d = tmp_path / f"m{module_mm:g}_{len(list(tmp_path.iterdir()))}"
    d.mkdir()
    (d / "model.toml").write_text(_iso_pair_toml(module_mm, statics=statics))
    return load_model(d / "model.toml")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("HACGEAR_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_iso_gear_fe_size_does_not_grow_with_the_module(tmp_path):
    """An ISO-form 28-tooth gear at module 1 and 45 mm: the module-scaled FE model has the same DOF count within
    2 % (the old absolute 0.6 mm / 3 mm sizes gave module 45 about 80 x the elements of module 5) and the same
    flank sample count; at m_n = 5 mm the scaled lengths are the absolute ones exactly."""
    dofs, samples = {}, {}
    for m in (1.0, 45.0):
        model = _iso_model(tmp_path, m)
        g = model.gears[0]
        assert fe_mod.length_scale(g, model.statics.fe_lengths) == pytest.approx(m / 5.0, rel=1e-15)
        opts = fe_mod.gear_mesh_options(g, model.statics.fe_lengths)
        assert opts.flank_size_m == pytest.approx(0.12 * m * 1e-3, rel=1e-12)
        assert opts.body_size_m == pytest.approx(0.6 * m * 1e-3, rel=1e-12)
        gg = gear_geometry(g)
        fe = fe_mod.build_gear_fe(gg, fe_mod.ElasticMaterial(206e9, 0.3), opts)
        dofs[m] = fe.n_dofs
        c = fe_mod.gear_compliance(gg, fe_mod.ElasticMaterial(206e9, 0.3), "drive", options=opts, cache=False, fe=fe,
                                   **fe_mod.compliance_lengths(g, model.statics.fe_lengths))
        samples[m] = c.s_m.size
    assert abs(dofs[45.0] / dofs[1.0] - 1.0) < 0.02, dofs
    assert samples[1.0] == samples[45.0], samples
    g5 = _iso_model(tmp_path, 5.0).gears[0]
    assert fe_mod.gear_mesh_options(g5) == fe_mod.MeshOptions()
    assert fe_mod.compliance_lengths(g5) == fe_mod.COMPLIANCE_LENGTHS_M


def test_fe_lengths_key(tmp_path):
    """``[statics] fe_lengths``: auto (default) scales ISO-form gears; absolute keeps the fixed lengths for them;
    module scales a transverse-form gear; another value is refused naming the key and the choices."""
    iso_abs = _iso_model(tmp_path, 45.0, '[statics]\nfe_lengths = "absolute"\n')
    assert fe_mod.length_scale(iso_abs.gears[0], iso_abs.statics.fe_lengths) is None
    assert fe_mod.gear_mesh_options(iso_abs.gears[0], "absolute") == fe_mod.MeshOptions()
    spur = load_model("spur_28t_asym")
    assert spur.gears[0].iso is None and spur.statics.fe_lengths == "auto"
    assert fe_mod.length_scale(spur.gears[0], "auto") is None
    assert fe_mod.length_scale(spur.gears[0], "module") == 1.0      # module 5 mm: the absolute lengths exactly
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "model.toml").write_text(_iso_pair_toml(5.0, statics='[statics]\nfe_lengths = "modul"\n'))
    with pytest.raises(ModelError, match=r"statics\.fe_lengths.*auto \| module \| absolute"):
        load_model(tmp_path / "bad" / "model.toml")
    with pytest.raises(ModelError, match="fe_lengths"):
        fe_mod.length_scale(spur.gears[0], "relative")
    # the corner radius of a sharp tip scales too (ISO module 45: 0.1 mm x 9)
    iso = _iso_model(tmp_path, 45.0)
    assert default_contact_options(iso, "m").corner_radius_m == pytest.approx(0.9e-3, rel=1e-12)
    assert default_contact_options(spur, spur.meshes[0].name) == ContactOptions(face_slices=spur.statics.face_slices)


def test_shipped_pair_fe_model_and_solution_unchanged(cache):
    """The shipped 28-tooth pair (transverse form): the solver built with the defaults equals, bit for bit, one
    built with the explicit absolute lengths of before (MeshOptions(), 0.25 / 0.5 / 1.0 mm sampling, 0.1 mm corner
    radius): same FE node count, compliances and a solved mesh force."""
    model = load_model("spur_28t_asym")
    mesh = model.meshes[0].name
    now = make_mesh_solver(model, mesh, cache=False)
    old = make_mesh_solver(model, mesh, cache=False, fe_options=fe_mod.MeshOptions(),
                           options=ContactOptions(face_slices=model.statics.face_slices, corner_radius_m=0.1e-3))
    for a, b in zip(now.compliance, old.compliance):
        assert a.info["n_dofs"] == b.info["n_dofs"]
        assert a.info["cache_key"] == b.info["cache_key"]
        np.testing.assert_array_equal(a.far_field_m2_N, b.far_field_m2_N)
    assert now.options == old.options
    s_now = now.solve_deflection(0.3, 20e-6)
    s_old = old.solve_deflection(0.3, 20e-6)
    assert s_now.mesh_force_N == s_old.mesh_force_N and s_now.mesh_force_N > 0
    np.testing.assert_array_equal(s_now.tooth_load_N, s_old.tooth_load_N)


def test_prebuild_builds_each_gear_once(cache, tmp_path, monkeypatch):
    """prebuild_compliances (run by compute_statics before its workers) meshes and factorises each gear once for
    both sides, fills the cache, and solvers built afterwards build no FE model."""
    model = _iso_model(tmp_path, 5.0)
    calls = []
    real = fe_mod.build_gear_fe

    def counting(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(fe_mod, "build_gear_fe", counting)
    assert prebuild_compliances(model, sides=("drive", "coast")) == {"pinion": 1, "wheel": 1}
    assert len(calls) == 2
    assert prebuild_compliances(model, sides=("drive", "coast")) == {"pinion": 0, "wheel": 0}

    def refuse(*a, **k):
        raise AssertionError("a solver built after prebuild_compliances built an FE model")

    monkeypatch.setattr(fe_mod, "build_gear_fe", refuse)
    for side in ("drive", "coast"):
        kw = mesh_solver_inputs(model, "m", side=side)
        assert all(c.info["options"] == fe_mod.asdict(fe_mod.MeshOptions()) for c in kw["compliance"])


def test_statics_face_coupling_option(tmp_path, capsys):
    """``hacgear statics --face-coupling`` (the choices of ``stiffness``): the factory builds the solver with it;
    without it the solvers' defaults (spur: rigid) as before; refused with --check and with --solver analytic."""
    from hacgear_core.cli import main
    from hacgear_core.model.provenance import model_values_sha256
    from hacgear_core.statics.grid import ModelSolverFactory

    model = load_model("spur_28t_asym")
    mesh = model.meshes[0].name
    sha = model_values_sha256(model)
    default = ModelSolverFactory(str(model.path), mesh, sha)()
    sliced = ModelSolverFactory(str(model.path), mesh, sha, "fe", "drive", "slices")()
    assert default.options.face_coupling == "rigid" and "(rigid)" in default.description
    assert sliced.options.face_coupling == "slices" and "(slices)" in sliced.description
    assert replace(sliced.options, face_coupling="rigid") == default.options
    with pytest.raises(SystemExit):
        main(["statics", "spur_28t_asym", "--face-coupling", "bogus"])
    capsys.readouterr()
    assert main(["statics", "spur_28t_asym", "--check", "--face-coupling", "slices"]) == 2
    assert "--face-coupling: no effect with --check" in capsys.readouterr().err
    assert main(["statics", "spur_28t_asym", "--solver", "analytic", "--face-coupling", "slices",
                 "--out", str(tmp_path / "t.h5")]) == 2
    assert "--face-coupling applies to the finite-element solver" in capsys.readouterr().err


def test_statics_refuses_a_table_of_another_face_coupling(cache, tmp_path):
    """A table (or partial run) solved with one face coupling is neither resumed nor accepted as complete by a run
    that asks for another; the same coupling finds it complete."""
    from hacgear_core.errors import TableError
    from hacgear_core.statics.grid import compute_statics

    model = _iso_model(tmp_path, 5.0, "[statics]\nface_slices = 3\n")
    out = tmp_path / "t.h5"
    kw = dict(positions=2, loads=2, deflections=4, workers=1, progress=False, sides=("drive",))
    assert compute_statics(model.path, out, **kw).success
    with pytest.raises(TableError, match="face coupling 'rigid', this run asks for 'slices'"):
        compute_statics(model.path, out, face_coupling="slices", **kw)
    again = compute_statics(model.path, out, face_coupling="rigid", **kw)
    assert again.success and "already complete" in again.message


def test_ring_rack_root_radius_038_mn_accepted_at_module_45(tmp_path):
    """The NREL stage-1 ring (z 56, x -0.501, module 45) with rack A's root radius 0.38 m_n = 17.1 mm (refused
    before): accepted, its shaper cut with the full radius its tip holds, the same multiple of m_n as at module 5,
    said in the warnings; its module-scaled FE model builds."""
    from hacgear_core.geometry import max_hob_tip_radius_m

    def ring(m_mm):
        text = textwrap.dedent(f"""\
            [system]
            name = "ring_a"
            kind = "planetary"
            [materials.steel]
            density_kg_per_m3 = 7830.0
            youngs_modulus_GPa = 206.0
            poisson_ratio = 0.3
            """)
        for name, z, x, k, bore, extra in (("sun", 19, 0.617, -10.861, 400.0, ""), ("planet", 17, 0.802, -10.861,
                                                                                      400.0, ""),
                                           ("ring", 56, -0.501, 0.0, 3024.0, "internal = true\n")):
            s = m_mm / 45.0
            text += (f'[[gears]]\nname = "{name}"\nteeth = {z}\n{extra}normal_module_mm = {m_mm!r}\n'
                     f'normal_pressure_angle_deg = 20.0\nprofile_shift = {x}\ntip_alteration_mm = {k * s!r}\n'
                     f'basic_rack = "A"\nthickness_allowance_upper_mm = {-0.30 * s!r}\n'
                     f'thickness_allowance_lower_mm = {-0.60 * s!r}\nface_width_mm = {491.0 * s!r}\n'
                     f'bore_diameter_mm = {bore * s!r}\nmaterial = "steel"\n')
        text += textwrap.dedent(f"""\
            [[meshes]]
            name = "sun_planet"
            gear_a = "planet"
            gear_b = "sun"
            center_distance_mm = {863.0 * m_mm / 45.0!r}
            [[meshes]]
            name = "ring_planet"
            gear_a = "ring"
            gear_b = "planet"
            flank_a = "drive"
            flank_b = "coast"
            center_distance_mm = {863.0 * m_mm / 45.0!r}
            [planetary]
            planet_count = 3
            carrier_radius_mm = {863.0 * m_mm / 45.0!r}
            fixed_member = "ring"
            output_member = "sun"
            [damping]
            modal_damping_ratio = 0.02
            [operating]
            torque_Nm = 1.0e5
            torque_gear = "carrier"
            """)
        d = tmp_path / f"ring{m_mm:g}"
        d.mkdir()
        (d / "model.toml").write_text(text)
        return load_model(d / "model.toml").gear("ring")

    r45, r5 = ring(45.0), ring(5.0)
    assert r45.hob_tip_radius_m == pytest.approx(17.1e-3, rel=1e-12)
    gg = gear_geometry(r45)
    assert any("0.38 m_n = 17.1000 mm" in w and "full radius" in w for w in gg.warnings)
    assert gg.hob_tip_radius_m == pytest.approx(max_hob_tip_radius_m(r45), rel=1e-8)
    assert gg.hob_tip_radius_m / 45e-3 == pytest.approx(gear_geometry(r5).hob_tip_radius_m / 5e-3, rel=1e-6)
    fe = fe_mod.build_gear_fe(gg, fe_mod.ElasticMaterial(206e9, 0.3), fe_mod.gear_mesh_options(r45))
    assert fe.n_dofs > 0


def test_face_discretisation_follows_the_face_width_and_the_slices(tmp_path):
    """3D face model (fe3d): the transverse form keeps the default options; an ISO-form gear gets them scaled with
    the module, with at most one face layer and two influence-grid intervals per face slice (a 140 mm face at m_n
    14 mm and 11 slices: 11 layers and 22 intervals, where the module-scaled 4.48 mm layers alone gave 32)."""
    from hacgear_core.statics import fe3d

    for g in load_model("helical_28_33").gears:
        assert fe3d.gear_mesh3d_options(g, "auto", 11) == fe3d.Mesh3DOptions()
    g = _iso_model(tmp_path, 14.0).gears[0]
    o = fe3d.gear_mesh3d_options(g, "auto", 11)
    assert o.flank_size_m == pytest.approx(1e-3 * 14.0 / 5.0, rel=1e-12)
    b = g.face_width_m
    assert int(np.ceil(b / fe3d.Mesh3DOptions().scaled(2.8).layer_size_m)) == 32
    assert int(np.ceil(b / o.layer_size_m)) == 11
    assert int(np.ceil(b / o.z_spacing_m)) == 22
    assert fe3d.gear_mesh3d_options(g, "absolute", 11) == fe3d.Mesh3DOptions()

"""The three NREL 5 MW reference gearbox stages shipped in the ISO 21771 form (models/nrel_5mw_stage1..3; Nejad, Guo,
Gao, Moan 2016, Wind Energy 19, doi 10.1002/we.1884, Table V; issue #51 item 6): each file loads unchanged, `hacgear
info --json` reports the ISO quantities, and they equal the ISO 21771 closed forms of the published data within 1e-9
relative; the stages' ratios come out of the assembled systems' rigid-body modes (planetary stages) and the gear teeth
(stage 3), their product the gearbox's 4625/48 = 96.354166..."""
from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest

from hacgear_core.cli import main
from hacgear_core.cli.info import info_dict
from hacgear_core.geometry.planetary import planetary_geometry
from hacgear_core.kinds import build_system, load_model
from test_planetary import _constant_tables as planetary_constant_tables
from hacgear_core.model import shipped_systems_dir

REL = 1e-9
ALPHA_N = math.radians(20.0)

#: the published data (issue #51 table = Nejad et al. 2016 Table V): per gear (z, x, k m_n [mm], internal), per stage
#: m_n [mm], beta [deg], b [mm], a_w [mm], the meshes (gear_a, gear_b) in the file's order (the driver first)
STAGES = {
    "nrel_5mw_stage1": dict(m_n=45.0, beta=0.0, b=491.0, a_w=863.0,
                            gears={"sun": (19, 0.617, -10.861, False), "planet": (17, 0.802, -10.861, False),
                                   "ring": (56, -0.501, 0.0, True)},
                            meshes={"sun_planet": ("planet", "sun"), "ring_planet": ("ring", "planet")}),
    "nrel_5mw_stage2": dict(m_n=21.0, beta=0.0, b=550.0, a_w=584.0,
                            gears={"sun": (18, 0.389, -1.75, False), "planet": (36, 0.504, -1.75, False),
                                   "ring": (93, 0.117, 0.0, True)},
                            meshes={"sun_planet": ("planet", "sun"), "ring_planet": ("ring", "planet")}),
    "nrel_5mw_stage3": dict(m_n=14.0, beta=10.0, b=360.0, a_w=861.0,
                            gears={"wheel": (95, 0.669, -0.938, False), "pinion": (24, 0.480, -0.938, False)},
                            meshes={"m12": ("wheel", "pinion")}),
}

#: each stage's speed-up ratio output speed / input speed: sun / carrier = 1 + z_r/z_s, pinion / wheel = z_w / z_p
RATIOS = {"nrel_5mw_stage1": 1 + Fraction(56, 19), "nrel_5mw_stage2": 1 + Fraction(93, 18),
          "nrel_5mw_stage3": Fraction(95, 24)}


def inv(a: float) -> float:
    return math.tan(a) - a


def _closed_forms(stage: str, name: str, model) -> dict:
    """ISO 21771 d, d_a, d_f, d_b [m], alpha_t [rad], the nominal normal tooth thickness s_n and the modelled one
    (at the mean allowance) [m] of the published gear."""
    s = STAGES[stage]
    z, x, k_mm, internal = s["gears"][name]
    m_n, beta = s["m_n"] * 1e-3, math.radians(s["beta"])
    iso = model.gear(name).iso
    alpha_t = math.atan(math.tan(ALPHA_N) / math.cos(beta))
    d = z * m_n / math.cos(beta)
    sg = -1.0 if internal else 1.0
    s_n = m_n * (math.pi / 2 + 2 * x * math.tan(ALPHA_N))
    return dict(d=d, d_a=d + sg * (2 * m_n * (iso.addendum_coefficient + x) + 2 * k_mm * 1e-3),
                d_f=d - sg * 2 * m_n * (iso.dedendum_coefficient - x), d_b=d * math.cos(alpha_t), alpha_t=alpha_t,
                s_n=s_n, s_n_mean=s_n + 0.5 * (iso.thickness_allowance_upper_m + iso.thickness_allowance_lower_m))


@pytest.fixture(scope="module", params=list(STAGES))
def stage(request):
    model = load_model(request.param)
    return request.param, model, info_dict(model)


def test_stage_files_are_iso_form_and_info_json_reports_the_iso_quantities(stage, capsys):
    """Each shipped file loads as written (every gear in the ISO form, the planetary stages carrier in / sun out,
    ring fixed) and `hacgear info --json` carries d, d_a, d_f, d_b, x, s_n per gear and a_w, alpha_wt, eps_alpha,
    eps_beta, eps_gamma and the backlash per mesh; warnings only for stage 1's ring: rack A's root radius
    (0.38 m_n, as published) is more than its shaper's tip carries, the ring is cut with the shaper's full tip."""
    name, model, _ = stage
    assert (shipped_systems_dir() / name / "readme.md").exists()
    assert main(["info", name, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    if name == "nrel_5mw_stage1":
        assert len(d["warnings"]) == 1 and d["warnings"][0].startswith("gear 'ring': the basic rack's root radius "
                                                                       "rho_fP = 0.38 m_n")
        assert "full radius 13.5265 mm = 0.300588 m_n" in d["warnings"][0]
    else:
        assert d["warnings"] == []
    for g in STAGES[name]["gears"]:
        iso = d["gears"][g]["iso"]
        assert iso["form"] == "iso21771"
        for key in ("reference_diameter_m", "tip_diameter_m", "root_diameter_m", "profile_shift",
                    "normal_tooth_thickness_m"):
            assert math.isfinite(iso[key]), key
        assert math.isfinite(iso["base_diameter_m"]["drive"])
    for m in STAGES[name]["meshes"]:
        iso = d["meshes"][m]["iso"]
        for key in ("center_distance_m", "operating_transverse_pressure_angle_deg", "transverse_contact_ratio",
                    "overlap_ratio", "total_contact_ratio", "backlash_circular_m", "backlash_circular_min_m",
                    "backlash_circular_max_m"):
            assert math.isfinite(iso[key]), key
        assert 0.0 < iso["backlash_circular_min_m"] < iso["backlash_circular_m"] < iso["backlash_circular_max_m"]
    if model.kind == "planetary":
        assert model.operating.torque_gear == "carrier" and model.planetary.output_member == "sun"
        assert model.planetary.fixed_member == "ring" and model.planetary.planet_count == 3
        assert planetary_geometry(model).power_flow.arrangement == "carrier in, sun out, ring fixed"


def test_gears_equal_the_iso_closed_forms(stage):
    """d = z m_n / cos(beta), d_a = d +- 2 m_n (h_aP* + x + k), d_f = d -+ 2 m_n (h_fP* - x), d_b = d cos(alpha_t),
    x with ISO 21771's sign (internal gears too) and s_n = m_n (pi/2 + 2 x tan(alpha_n)) (nominal; the modelled
    teeth at the mean thickness allowance) from the published data, within 1e-9 relative of `info`."""
    name, model, info = stage
    for g, (z, x, k_mm, internal) in STAGES[name]["gears"].items():
        cf = _closed_forms(name, g, model)
        iso = info["gears"][g]["iso"]
        assert iso["normal_module_m"] == pytest.approx(STAGES[name]["m_n"] * 1e-3, rel=REL)
        assert iso["helix_angle_deg"] == pytest.approx(STAGES[name]["beta"], rel=REL, abs=1e-12)
        assert iso["profile_shift"] == pytest.approx(x, rel=REL)
        assert iso["tip_alteration_m"] == pytest.approx(k_mm * 1e-3, rel=REL, abs=1e-15)
        assert iso["reference_diameter_m"] == pytest.approx(cf["d"], rel=REL)
        assert iso["tip_diameter_m"] == pytest.approx(cf["d_a"], rel=REL)
        assert iso["root_diameter_m"] == pytest.approx(cf["d_f"], rel=REL)
        for fl in ("drive", "coast"):
            assert iso["base_diameter_m"][fl] == pytest.approx(cf["d_b"], rel=REL)
            assert math.radians(iso["transverse_pressure_angle_deg"][fl]) == pytest.approx(cf["alpha_t"], rel=REL)
        assert iso["nominal_normal_tooth_thickness_m"] == pytest.approx(cf["s_n"], rel=REL)
        assert iso["normal_tooth_thickness_m"] == pytest.approx(cf["s_n_mean"], rel=REL)
        assert model.gear(g).teeth == z and model.gear(g).internal == internal


def test_meshes_equal_the_iso_closed_forms(stage):
    """At the published a_w: cos(alpha_wt) = a cos(alpha_t) / a_w (a = m_t |z_1 + z_2| / 2, signed z); the a_w of the
    profile shifts from inv(alpha_wt) = inv(alpha_t) + 2 tan(alpha_n) (x_1 + x_2) / (z_1 + z_2); eps_beta = b sin(beta)
    / (pi m_n); eps_alpha from the tip and base circles; eps_gamma = eps_alpha + eps_beta; the circular backlash on the
    operating pitch circle p_wt - s_wt1 - s_wt2 (internal: e_wt,ring - s_wt,planet) at the modelled (mean) teeth and
    at the upper and lower allowances, all within 1e-9 relative of `info`."""
    from scipy.optimize import brentq

    name, model, info = stage
    s = STAGES[name]
    m_n, beta, a_w, b = s["m_n"] * 1e-3, math.radians(s["beta"]), s["a_w"] * 1e-3, s["b"] * 1e-3
    m_t = m_n / math.cos(beta)
    for mesh, (ga, gb) in s["meshes"].items():
        iso = info["meshes"][mesh]["iso"]
        (z1, x1, _, i1), (z2, x2, _, i2) = s["gears"][ga], s["gears"][gb]
        z1s, z2s = (-z1 if i1 else z1), (-z2 if i2 else z2)
        c1, c2 = _closed_forms(name, ga, model), _closed_forms(name, gb, model)
        alpha_t = c1["alpha_t"]
        a = m_t * abs(z1s + z2s) / 2
        alpha_wt = math.acos(a * math.cos(alpha_t) / a_w)
        assert iso["center_distance_m"] == pytest.approx(a_w, rel=REL)
        assert math.radians(iso["operating_transverse_pressure_angle_deg"]) == pytest.approx(alpha_wt, rel=REL)
        assert iso["sum_profile_shift"] == pytest.approx(x1 + x2, rel=REL)
        target = inv(alpha_t) + 2 * math.tan(ALPHA_N) * (x1 + x2) / (z1s + z2s)
        awt0 = brentq(lambda t: inv(t) - target, 1e-3, 1.2, xtol=1e-15, rtol=1e-15)
        assert iso["center_distance_from_profile_shifts_m"] == pytest.approx(a * math.cos(alpha_t) / math.cos(awt0),
                                                                             rel=REL)
        # transverse contact ratio: internal gears subtract their tip-circle term and add a_w sin(alpha_wt)
        rb1, rb2, ra1, ra2 = c1["d_b"] / 2, c2["d_b"] / 2, c1["d_a"] / 2, c2["d_a"] / 2
        t1, t2 = math.sqrt(ra1 ** 2 - rb1 ** 2), math.sqrt(ra2 ** 2 - rb2 ** 2)
        p_bt = math.pi * m_t * math.cos(alpha_t)
        if i1 or i2:
            g_a = (t2 - t1 if i1 else t1 - t2) + a_w * math.sin(alpha_wt)
        else:
            g_a = t1 + t2 - a_w * math.sin(alpha_wt)
        eps_a, eps_b = g_a / p_bt, b * math.sin(beta) / (math.pi * m_n)
        assert iso["transverse_contact_ratio"] == pytest.approx(eps_a, rel=REL)
        assert iso["overlap_ratio"] == pytest.approx(eps_b, rel=REL, abs=1e-12)
        assert iso["total_contact_ratio"] == pytest.approx(eps_a + eps_b, rel=REL)
        # backlash on the operating pitch circle (lengths equal on both gears' pitch circles)
        d_w1 = a_w * 2 * abs(z1s) / abs(z1s + z2s)

        def thickness_or_space(c, z, internal, s_n):
            """s_wt of an external gear, e_wt (space width) of an internal one, on its operating pitch circle."""
            d, s_t = c["d"], s_n / math.cos(beta)
            w = math.pi * d / z - s_t if internal else s_t
            return (d_w1 * z / z1) * (w / d + inv(alpha_t) - inv(alpha_wt))

        p_w = math.pi * d_w1 / z1

        def backlash(key):
            w1 = thickness_or_space(c1, z1, i1, c1[key])
            w2 = thickness_or_space(c2, z2, i2, c2[key])
            if i1:
                return w1 - w2
            if i2:
                return w2 - w1
            return p_w - w1 - w2

        assert iso["backlash_circular_m"] == pytest.approx(backlash("s_n_mean"), rel=REL)
        for key, lim in (("backlash_circular_min_m", "upper"), ("backlash_circular_max_m", "lower")):
            for c, g in ((c1, ga), (c2, gb)):
                c["s_lim"] = c["s_n"] + getattr(model.gear(g).iso, f"thickness_allowance_{lim}_m")
            assert iso[key] == pytest.approx(backlash("s_lim"), rel=REL)


def _constant_tables(model, k: float) -> dict:
    """Constant-stiffness tables of a planetary stage's two meshes in the file's gear order (no statics run: the
    rigid-body mode does not depend on the mesh stiffness)."""
    return planetary_constant_tables(model, k, model.operating.torque_Nm, model.planetary.planet_count)


def _planetary_ratio(name: str) -> float:
    """Sun / carrier speed of the assembled stage in drivetrain mode (carrier and sun free, ring held): the null
    vector of ``K + V^T k V`` (supports and mesh stiffnesses) with the carrier's rotation 1."""
    model = load_model(name)
    sy = build_system(model, _constant_tables(model, 1e10), shafts=False)
    k = sy.K + (sy.V.T * sy.mesh_stiffness_N_per_m) @ sy.V
    i, j = sy.gears["carrier"].rotation, sy.gears["sun"].rotation
    rest = [n for n in range(sy.n) if n != i]
    u = np.zeros(sy.n)
    u[i] = 1.0
    u[rest] = np.linalg.solve(k[np.ix_(rest, rest)], -k[rest, i])
    # the builder's own rigid mode turns the sun at the same ratio
    assert sy.rigid_mode[j] / sy.rigid_mode[i] == pytest.approx(u[j] / u[i], rel=1e-12)
    return u[j] / u[i]


def test_stage_ratios_and_the_gearbox_ratio():
    """Stages 1 and 2 (carrier in, sun out, ring fixed): the assembled system's rigid-body mode turns the sun
    1 + z_r/z_s times as fast as the carrier, 1 + 56/19 and 1 + 93/18, to 1e-12; stage 3: the wheel drives the
    pinion 95/24 times faster, the ratio of the base radii (the mesh deflection's arms), to 1e-12; the gearbox's overall ratio is
    their product, exactly 4625/48 = 96.354166... as a fraction and to 1e-12 from the measured ratios."""
    measured = {n: _planetary_ratio(n) for n in ("nrel_5mw_stage1", "nrel_5mw_stage2")}
    info3 = info_dict(load_model("nrel_5mw_stage3"))["meshes"]["m12"]
    rb = info3["base_radius_m"]
    measured["nrel_5mw_stage3"] = rb["wheel"] / rb["pinion"]
    for n, r in measured.items():
        assert r == pytest.approx(float(RATIOS[n]), rel=1e-12), n
    total = RATIOS["nrel_5mw_stage1"] * RATIOS["nrel_5mw_stage2"] * RATIOS["nrel_5mw_stage3"]
    assert total == Fraction(4625, 48)
    assert math.prod(measured.values()) == pytest.approx(4625 / 48, rel=1e-12)


@pytest.mark.parametrize("name", ["nrel_5mw_stage1", "nrel_5mw_stage2"])
def test_rated_static_mesh_forces_equal_the_torque_balance(name):
    """The shipped planetary stages at their rated carrier torque (constant-stiffness tables in the file's gear order):
    the static solve converges and carries F_s = T_s / (N r_b,s) on every sun mesh and F_r = T_r / (N r_b,r) on every
    ring mesh, T_s = T_c / (1 + z_r/z_s), T_r = T_s z_r/z_s, to 1e-9; the power enters by the carrier and leaves by
    the sun.  The sun's rotation is prescribed (the constant-speed experiment holds the output, as the shipped
    65/55/175 set holds its carrier): it grounds the train through the meshes, no rigid-body mode is left."""
    from hacgear_core.dynamics.equilibrium import static_equilibrium

    model = load_model(name)
    assert model.gear("sun").support.rotational_stiffness_Nm_per_rad == math.inf
    assert model.planetary.carrier_support.rotational_stiffness_Nm_per_rad == 0.0
    sy = build_system(model, _constant_tables(model, 1e10))
    geo = planetary_geometry(model)
    zs, zr = model.gear("sun").teeth, model.gear("ring").teeth
    t_c = model.operating.torque_Nm
    t_s = t_c / (1 + zr / zs)
    rbs = geo.sun_mesh(1).base_radius_m[1]              # planet -> sun: the sun is gear_b
    rbr = geo.ring_mesh(1).base_radius_m[0]             # ring -> planet: the ring is gear_a
    assert (geo.sun_mesh(1).gear_b, geo.ring_mesh(1).gear_a) == ("sun", "ring")
    eq = static_equilibrium(sy, 0.0)
    sun = np.array([c.group == "sun_planet" for c in sy.meshes])
    assert sun.sum() == 3 and (~sun).sum() == 3
    np.testing.assert_allclose(eq.mesh_forces_N[sun], t_s / (3 * rbs), rtol=1e-9)
    np.testing.assert_allclose(eq.mesh_forces_N[~sun], t_s * zr / zs / (3 * rbr), rtol=1e-9)
    assert sy.rigid_mode is None and sy.gears["sun"].rotation == -1
    sd = build_system(model, _constant_tables(model, 1e10), shafts=False)  # drivetrain mode: the sun a torque port
    fe, w = sd.fext_speed(), sd.rigid_mode
    i_c, i_s = sd.gears["carrier"].rotation, sd.gears["sun"].rotation
    p_in = fe[i_c] * w[i_c] * sd.gears["carrier"].sense
    p_out = fe[i_s] * w[i_s] * sd.gears["carrier"].sense
    assert p_in > 0 > p_out and p_in + p_out == pytest.approx(0.0, abs=1e-9 * p_in)

"""The multi-stage parallel-axis gearbox (kind gear_train): model rules, placement, tables, modes against an
independent eigen-solution of the lumped matrices written here, shaft torque, FMUs."""
from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
import scipy.linalg

from hacgear_core.cli import main
from hacgear_core.errors import ModelError
from hacgear_core.geometry import gear_geometry, train_geometry
from hacgear_core.kinds import build_system, load_model, parse_model
from hacgear_core.kinds.gear_train import mesh_rates, place_gear_train
from hacgear_core.model import resolve_model_path
from hacgear_core.tables import load_system_tables

SYSTEM = "gear_train_2stage"
#: m34 (mirror-image gears) against spur_28t_asym: largest static-deflection difference over the largest deflection
MIRROR_TOLERANCE = 2e-3  # measured 7.5e-4 (FE meshes of mirror-image gears are not mirror images)
#: two-FMU bench against the one-FMU train at the finest communication step: mesh force ranges (relative)
BENCH_TOLERANCE = 0.02


def _text(system: str = SYSTEM) -> str:
    return resolve_model_path(system).read_text()


@pytest.fixture(scope="module")
def model():
    return load_model(SYSTEM)


@pytest.fixture(scope="module")
def system(model):
    return build_system(model, load_system_tables(SYSTEM))


def _idler_as_gear_train(torsional: float = 1.0e6) -> str:
    """idler_28_33_39 with its idler split into two identical gears on one shaft, the shafts to ground removed."""
    txt = _text("idler_28_33_39").replace('kind = "idler_chain"', 'kind = "gear_train"')
    txt = txt.replace("rotational_stiffness_Nm_per_rad = 5.0e4", "rotational_stiffness_Nm_per_rad = 0.0")
    i = txt.index('[[gears]]\nname = "gear2"')
    j = txt.index("[[gears]]", i + 5)
    txt = txt[:j] + txt[i:j].replace('name = "gear2"', 'name = "gear2b"') + txt[j:]
    txt = txt.replace('gear_a = "gear2"\ngear_b = "gear3"', 'gear_a = "gear2b"\ngear_b = "gear3"')
    return txt.replace("[damping]", f'[[gear_train.shafts]]\nname = "s2"\ngear_a = "gear2"\ngear_b = "gear2b"\n'
                                    f"torsional_stiffness_Nm_per_rad = {torsional!r}\n\n[damping]")


def test_an_idler_split_on_a_shaft_is_placed_as_the_idler_chain():
    """Two identical gears on one shaft, mounted without offset, are the idler of idler_28_33_39: same lines of
    action, phases and tooth passage of the gear driving m23 (the placement joins two independently placed pairs)."""
    idler = load_model("idler_28_33_39")
    gt = parse_model(_idler_as_gear_train())
    a, b = train_geometry(idler), place_gear_train(gt)
    for m in ("m12", "m23"):
        assert b.meshes[m].phase == pytest.approx(a.meshes[m].phase, abs=1e-12)
        np.testing.assert_allclose(b.meshes[m].line_of_action, a.meshes[m].line_of_action, atol=1e-15)
    assert a.meshes["m23"].phase == pytest.approx(0.98622, abs=1e-5)
    assert b.tooth_passage["gear2b"]["m23"] == a.tooth_passage["gear2"]["m23"]
    np.testing.assert_allclose(b.centre_m["gear2b"], b.centre_m["gear2"])
    assert b.sense["gear2b"] == b.sense["gear2"] == -1.0


def test_mounting_angle_moves_the_second_stage_phase():
    """Turning pinion2 by d on the shaft (counter-clockwise) delays m34 by z d / 2 pi: pinion2 turns clockwise."""
    base = _text()
    ph = {}
    for deg in (0.0, 1.0):
        txt = re.sub(r"mounting_angle_deg = [0-9.eE+-]+", f"mounting_angle_deg = {deg}", base)
        ph[deg] = place_gear_train(parse_model(txt)).meshes["m34"].phase
    assert (ph[0.0] - ph[1.0]) == pytest.approx(28 / 360, abs=1e-12)


def _hand_matrices(model, mesh_stiffness):
    """M and K of the two-stage train on rigid bearings written out by hand (q = rotations of pinion1, wheel1,
    pinion2, wheel2, counter-clockwise): J_i on M's diagonal; each external mesh x = r_b,a th_a + r_b,b th_b
    (dissertation Eq. 3.4, the sense of rotation only flips the sign of x) with r_b = m z cos(25 deg) / 2; the
    intermediate shaft k_s (th_wheel1 - th_pinion2)^2 / 2."""
    rb = 5.0e-3 * 28 * math.cos(math.radians(25.0)) / 2
    J = [gear_geometry(model.gear(g)).inertia_kgm2 for g in ("pinion1", "wheel1", "pinion2", "wheel2")]
    ks = 1.0e4  # [[gear_train.shafts]] torsional_stiffness_Nm_per_rad of the model file
    v1 = np.array([rb, rb, 0.0, 0.0])
    v2 = np.array([0.0, 0.0, rb, rb])
    s = np.array([0.0, 1.0, -1.0, 0.0])
    K = mesh_stiffness[0] * np.outer(v1, v1) + mesh_stiffness[1] * np.outer(v2, v2) + ks * np.outer(s, s)
    return np.diag(J), K, rb


def test_modes_equal_an_independent_eigen_solution_of_the_hand_written_matrices(model, system, capsys):
    """`hacgear modes` against scipy.linalg.eigh of M and K written here (the mesh stiffnesses are the tables'
    cycle-mean slopes at the static force the modes report; everything else from the model file by hand)."""
    assert main(["modes", SYSTEM, "--torque", "300", "--json", "--no-impulse"]) == 0
    rep = json.loads(capsys.readouterr().out)
    km = [rep["mesh_stiffness_N_per_m"][m] for m in ("m12", "m34")]
    assert km[0] == pytest.approx(km[1], rel=1e-3)          # both stages: the 25 deg flanks of the same pair
    assert km[0] == pytest.approx(164.29e6, rel=2e-3)       # spur_28t_asym's mesh stiffness (hacgear modes)
    M, K, rb = _hand_matrices(model, km)
    w2, phi = scipy.linalg.eigh(K, M)
    assert abs(w2[0]) < 1e-6 * w2[1]                        # the free rotation of the train
    f_hand = np.sqrt(w2[1:]) / (2 * math.pi)
    np.testing.assert_allclose(rep["natural_frequencies_Hz"], f_hand, rtol=1e-9)
    # the reference result of the readme: a shaft mode and two mesh modes either side of spur_28t_asym's 2786.4 Hz
    np.testing.assert_allclose(f_hand, [241.38, 2786.37, 2796.97], atol=0.01)
    assert rep["mode_shapes"]["dof_names"] == [f"{g}.theta" for g in ("pinion1", "wheel1", "pinion2", "wheel2")]
    for shape, col in zip(rep["mode_shapes"]["shapes"], phi[:, 1:].T):
        hand = col * rb
        np.testing.assert_allclose(shape, hand / hand[np.argmax(np.abs(hand))], atol=1e-7)
    assert rep["rigid_body_modes"] == 1
    np.testing.assert_array_equal(system.M, M)


def test_first_stage_table_is_spur_28t_asym_and_the_turned_over_stage_its_mirror_image():
    """m12 is spur_28t_asym's pair (same gears, grid and centre distance): the same statics give the same table;
    m34 loads the coast-side 25 deg flanks of the turned-over gears: the mirror image of the same contact problem."""
    ours = load_system_tables(SYSTEM)
    ref = load_system_tables("spur_28t_asym").mesh("m12")
    np.testing.assert_array_equal(ours.mesh("m12").force_N, ref.force_N)
    np.testing.assert_array_equal(ours.mesh("m12").deflection_m, ref.deflection_m)
    t = ours.mesh("m34")
    np.testing.assert_array_equal(t.load_N, ref.load_N)
    np.testing.assert_allclose(t.base_radius_m, ref.base_radius_m, rtol=1e-12)
    # load control: the static mesh deflection at every position and load of the grid
    err = np.max(np.abs(t.static_deflection_m - ref.static_deflection_m)) / np.max(ref.static_deflection_m)
    assert err < MIRROR_TOLERANCE, err


def test_static_shaft_torque_is_the_torque_the_first_stage_delivers(system):
    """Static equilibrium: pinion1 driven by 300 N m, wheel2 braked: the intermediate shaft carries F12 r_b2 =
    300 N m (unit ratio), whatever the mesh position (the wheel1 moment balance)."""
    from hacgear_core.dynamics.equilibrium import static_equilibrium

    i2, i3 = system.dof_names.index("wheel1.theta"), system.dof_names.index("pinion2.theta")
    s = system.gears["wheel1"].sense
    for tau in (0.0, 0.3, 0.7):
        eq = static_equilibrium(system, tau)
        assert s * 1.0e4 * (eq.q[i2] - eq.q[i3]) == pytest.approx(300.0, rel=1e-9)
    assert system.fext_speed()[i2] == 0.0 and system.fext_speed()[i3] == 0.0


def test_unequal_tooth_counts_run_each_mesh_at_its_own_rate():
    """28 -> 33 | 39 -> 39: the second stage meshes at (28/33) 39 / 28 = 13/11 of the first stage's frequency; the
    model loads, each mesh carries its reduced rate and the system repeats after 11 reference mesh cycles."""
    txt = _idler_as_gear_train()
    i = txt.index('[[gears]]\nname = "gear2b"')
    j = txt.index("[[gears]]", i + 5)
    k = txt.index('[[gears]]\nname = "gear3"')
    gear3 = txt[k:txt.index("[[meshes]]")]
    txt = txt[:i] + gear3.replace('name = "gear3"', 'name = "gear2b"') + txt[j:]
    model = parse_model(txt)
    assert mesh_rates(model) == {"m12": (1, 1), "m23": (13, 11)}


@pytest.mark.parametrize("edit, match", [
    (lambda t: t.replace("rotational_stiffness_Nm_per_rad = 0.0", "rotational_stiffness_Nm_per_rad = 5.0e4", 1),
     r"rotational_stiffness_Nm_per_rad \[N\*m/rad\] must be 0"),
    (lambda t: t.replace('gear_b = "pinion2"\ntorsional', 'gear_b = "pinion9"\ntorsional'),
     r"gear_train.shafts 'shaft2'.gear_b = 'pinion9' names no gear"),
    (lambda t: t.replace("torsional_stiffness_Nm_per_rad = 1.0e4", "torsional_stiffness_Nm_per_rad = 0.0"),
     r"torsional_stiffness_Nm_per_rad' \[N\*m/rad\].*allowed: \(0, 1e\+12\]"),
    (lambda t: t.replace("[damping]", '[[gear_train.shafts]]\nname = "s1"\ngear_a = "pinion1"\ngear_b = "wheel1"\n'
                                      'torsional_stiffness_Nm_per_rad = 1.0\n\n[damping]'),
     r"mesh 'm12': 'pinion1' and 'wheel1' are on one axis"),
    (lambda t: t.replace("[[gear_train.shafts]]", "[[gear_train.shaft]]"), r"unknown key 'gear_train.shaft'"),
    (lambda t: t.replace('torque_gear = "pinion1"', 'torque_gear = "wheel1"'),
     r"torque_gear = 'wheel1' must be at an end of the chain"),
])
def test_bad_gear_train_models_are_refused_at_load_naming_the_key(edit, match):
    with pytest.raises(ModelError, match=match):
        parse_model(edit(_text()))


def test_bending_spring_couples_the_translations_of_the_gears_on_a_shaft(model):
    """Elastic bearings (1e8 N/m) and a bending spring k_b between wheel1 and pinion2: both get x and y DOFs with
    K = [[k_t + k_b, -k_b], [-k_b, k_t + k_b]] per direction, each mesh's line-of-action vector n on them, and the
    modes equal scipy.linalg.eigh of M and K written here."""
    kt, kb = 1.0e8, 3.0e8
    txt = _text().replace("translational_stiffness_N_per_m = inf", f"translational_stiffness_N_per_m = {kt!r}")
    txt = txt.replace("torsional_stiffness_Nm_per_rad = 1.0e4",
                      f"torsional_stiffness_Nm_per_rad = 1.0e4\nbending_stiffness_N_per_m = {kb!r}")
    sy = build_system(parse_model(txt), load_system_tables(SYSTEM))
    names = list(sy.dof_names)
    assert names == ["pinion1.u_loa", "pinion1.theta", "wheel1.x", "wheel1.y", "wheel1.theta", "pinion2.x",
                     "pinion2.y", "pinion2.theta", "wheel2.u_loa", "wheel2.theta"]
    pl = place_gear_train(model)
    n12, n34 = pl.meshes["m12"].line_of_action, pl.meshes["m34"].line_of_action
    rb = 5.0e-3 * 28 * math.cos(math.radians(25.0)) / 2
    s1, s3 = pl.sense["pinion1"], pl.sense["pinion2"]
    # mesh deflection x = (u_a - u_b) . n + m_a th_a - m_b th_b with m_a = s_a r_b, m_b = -s_a r_b (external)
    v1 = np.zeros(10)
    v1[[0, 1, 2, 3, 4]] = [1.0, s1 * rb, -n12[0], -n12[1], s1 * rb]
    v2 = np.zeros(10)
    v2[[5, 6, 7, 8, 9]] = [n34[0], n34[1], s3 * rb, -1.0, s3 * rb]
    np.testing.assert_allclose(sy.V, [v1, v2], atol=1e-15)
    K = np.zeros((10, 10))
    K[[0, 8], [0, 8]] = kt
    for a, b in ((2, 5), (3, 6)):
        K[np.ix_([a, b], [a, b])] = [[kt + kb, -kb], [-kb, kt + kb]]
    K[np.ix_([4, 7], [4, 7])] = 1.0e4 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    np.testing.assert_allclose(sy.K, K, rtol=1e-15)
    geo = {g: gear_geometry(model.gear(g)) for g in ("pinion1", "wheel1", "pinion2", "wheel2")}
    m = [geo[name.split(".")[0]].inertia_kgm2 if name.endswith("theta") else geo[name.split(".")[0]].mass_kg
         for name in names]
    np.testing.assert_array_equal(np.diag(sy.M), m)
    kl = K + sum(k * np.outer(v, v) for k, v in zip(sy.mesh_stiffness_N_per_m, (v1, v2)))
    w2 = scipy.linalg.eigh(kl, np.diag(np.diag(sy.M)), eigvals_only=True)
    from hacgear_core.dynamics.modes import modal_analysis
    np.testing.assert_allclose(modal_analysis(sy).natural_frequencies_Hz, np.sqrt(w2[1:]) / (2 * math.pi),
                               rtol=1e-9)


def test_an_idler_split_on_a_stiff_shaft_has_the_idler_chains_dynamics():
    """idler_28_33_39 (free shafts) against the same chain with its idler cut into two halves (half the inertia
    each) on a 1e11 N m/rad shaft: the same nominal forces, the same static mesh forces and, below the shaft's own
    mode, the same natural frequencies (to (f / f_shaft)^2 ~ 1e-5)."""
    free = _text("idler_28_33_39").replace("rotational_stiffness_Nm_per_rad = 5.0e4",
                                           "rotational_stiffness_Nm_per_rad = 0.0")
    idler_model = parse_model(free)
    half = gear_geometry(idler_model.gear("gear2")).inertia_kgm2 / 2
    txt = _idler_as_gear_train(1.0e11).replace('name = "gear2"\n', f'name = "gear2"\ninertia_kgm2 = {half!r}\n')
    txt = txt.replace('name = "gear2b"\n', f'name = "gear2b"\ninertia_kgm2 = {half!r}\n')
    tabs = load_system_tables("idler_28_33_39")
    tables = {m: tabs.mesh(m) for m in ("m12", "m23")}
    idler = build_system(idler_model, tables)
    split = build_system(parse_model(txt), tables)
    np.testing.assert_allclose(split.nominal_forces_N(), idler.nominal_forces_N(), rtol=1e-12)
    np.testing.assert_allclose(split.phase, idler.phase, atol=1e-12)
    from hacgear_core.dynamics.equilibrium import static_equilibrium
    from hacgear_core.dynamics.modes import modal_analysis
    for tau in (0.0, 0.4):
        np.testing.assert_allclose(static_equilibrium(split, tau).mesh_forces_N,
                                   static_equilibrium(idler, tau).mesh_forces_N, rtol=1e-6)
    f_idler = modal_analysis(idler).natural_frequencies_Hz
    f_split = modal_analysis(split).natural_frequencies_Hz
    assert len(f_split) == len(f_idler) + 1 and f_split[-1] > 100 * f_idler[-1]
    np.testing.assert_allclose(f_split[:-1], f_idler, rtol=1e-4)


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    from hacgear_core.fmu import build_fmu

    return build_fmu(resolve_model_path(SYSTEM).parent, tmp_path_factory.mktemp("gear_train_fmu"))


def _fmu_run(path, names, speed=448.8, dt=1e-4, n=100):
    """``names`` of an FMU run at constant speed (pinion1 at ``speed`` [rad/s]: 2000 Hz mesh frequency)."""
    fmpy = pytest.importorskip("fmpy")
    return fmpy.simulate_fmu(str(path), stop_time=n * dt, output_interval=dt, output=names,
                             start_values={"pinion1.speed_in": speed, "internal_step": 2e-6})


FMU_OUTPUTS = ["m12.force", "m34.force", "m34.position", "wheel2.angle", "shaft2.torque"]


def test_gear_train_fmu_equals_the_library_and_outputs_the_shaft_torque(fmu):
    """The native FMI 2.0 FMU against the library's Simulator, step for step: mesh forces, positions, angles and
    the kind's extra output shaft2.torque = k_s (angle of wheel1 - angle of pinion2), which starts at the static
    300 N m and carries it on average; ports pinion1 (input) and wheel2 (output)."""
    from fmpy import read_model_description

    from hacgear_core.dynamics.simulator import Simulator

    md = {v.name: v for v in read_model_description(str(fmu)).modelVariables}
    assert md["shaft2.torque"].causality == "output" and md["shaft2.torque"].unit == "N.m"
    assert {"pinion1.torque_in", "wheel2.torque_in"} <= set(md) and "wheel1.torque_in" not in md
    res = _fmu_run(fmu, FMU_OUTPUTS)
    sim = Simulator(build_system(load_model(SYSTEM), load_system_tables(SYSTEM)), internal_step_s=2e-6)
    sim.reset(speed_rad_s=448.8)
    i1, i2, i4 = (sim.gear_index(g) for g in ("wheel1", "pinion2", "wheel2"))
    lib = {k: [] for k in FMU_OUTPUTS}
    for _ in range(100):
        assert sim.advance(1e-4).success
        for k, v in zip(FMU_OUTPUTS, (sim.mesh_force_N[0], sim.mesh_force_N[1], sim.mesh_position[1],
                                      sim.angle_rad[i4], 1.0e4 * (sim.angle_rad[i1] - sim.angle_rad[i2]))):
            lib[k].append(v)
    for k in FMU_OUTPUTS:
        v = np.asarray(lib[k])
        assert np.max(np.abs(res[k][1:] - v)) <= 1e-9 * np.max(np.abs(v)), k
    assert res["shaft2.torque"][0] == pytest.approx(300.0, rel=1e-6)
    assert np.mean(res["shaft2.torque"]) == pytest.approx(300.0, rel=0.01)


@pytest.mark.slow
def test_gear_train_fmus_of_both_backends_and_fmi_versions(fmu, tmp_path):
    """native and pythonfmu, FMI 2.0 and 3.0: each passes fmpy validate and fmutool -check, declares shaft2.torque
    and runs as the native FMI 2.0 FMU does (<= 1e-12 relative).  ``pytest -m slow tests/test_gear_train.py -k
    backends``."""
    import sys

    from hacgear_core.fmu import build_fmu

    root = resolve_model_path(SYSTEM).parents[2]
    sys.path.insert(0, str(root))
    try:
        import build_fmu as script
    finally:
        sys.path.remove(str(root))
    ref = _fmu_run(fmu, FMU_OUTPUTS)
    for backend in ("native", "pythonfmu"):
        for version in (2, 3):
            path = build_fmu(resolve_model_path(SYSTEM).parent, tmp_path / f"{backend}{version}", fmi_version=version,
                             backend=backend)
            assert script.validate_fmu(path) == [], (backend, version)
            res = _fmu_run(path, FMU_OUTPUTS)
            for k in FMU_OUTPUTS:
                assert np.max(np.abs(res[k] - ref[k])) <= 1e-12 * np.max(np.abs(ref[k])), (backend, version, k)


#: communication steps of the bench comparison [s] and the mesh frequencies [Hz] (away from resonance, at it)
BENCH_STEPS = (1e-5, 2e-5, 1e-4)
BENCH_FM = (1500.0, 2790.0)


def bench_comparison(out_dir, steps=BENCH_STEPS, mesh_frequencies=BENCH_FM, run_s=0.25, window_s=0.05):
    """The gear_train FMU (one FMU, the intermediate shaft inside its RK4) and the two-stage bench of two
    spur_28t_asym FMUs joined by a coupling shaft of the same stiffness (co-simulation: the shaft a component that
    exchanges torque and speed once per communication step), each between the bench's motor and load
    (:mod:`hacgear_core.fmu.bench`), at constant motor speed.  The coupling shaft's damper gives its torsion mode the
    model's modal damping ratio (c = 2 zeta sqrt(k J_w J_p / (J_w + J_p))), as the one FMU's modal damping does.
    Returns rows (mesh frequency [Hz], step [s], quantity, one FMU, two FMUs) over the last ``window_s`` of
    ``run_s``: each mesh's dynamic force range (max - min) [N] and the range of the intermediate shaft's elastic
    torque k (angle of wheel1 - angle of pinion2) [N m] from the FMUs' gear angles."""
    from hacgear_core.fmu import build_fmu
    from hacgear_core.fmu.bench import BenchConfig, FmuComponent, PythonComponent, drivetrain_layout, run_layout

    model = load_model(SYSTEM)
    one = build_fmu(resolve_model_path(SYSTEM).parent, out_dir)
    pair = build_fmu(resolve_model_path("spur_28t_asym").parent, out_dir)
    ks = model.section.shafts[0].torsional_stiffness_Nm_per_rad
    jw, jp = (gear_geometry(model.gear(g)).inertia_kgm2 for g in ("wheel1", "pinion2"))
    damper = 2 * model.damping.modal_damping_ratio * math.sqrt(ks * jw * jp / (jw + jp))
    angles = {"one": (("stage1", "wheel1.angle"), ("stage1", "pinion2.angle")),
              "two": (("stage1", "wheel.angle"), ("stage2", "pinion.angle"))}
    rows = []
    for fm in mesh_frequencies:
        for h in steps:
            rpm = fm / 28 * 60
            cfg = BenchConfig(speed_start_rpm=rpm, speed_end_rpm=rpm, ramp_s=run_s / 2, hold_s=run_s / 4, step_s=h,
                              load_torque_Nm=300.0, coupling_shaft_stiffness_Nm_per_rad=ks)
            res = {}
            for label, fmus in (("one", [one]), ("two", [pair, pair])):
                lay = drivetrain_layout(fmus, cfg)
                if label == "two":   # shaft1 is the coupling shaft between the stages
                    lay.components["shaft1"][1]["damping"] = damper
                lay.record += list(angles[label])
                comps = {n: PythonComponent(k, p) for n, (k, p) in lay.components.items()}
                try:
                    comps.update({n: FmuComponent(p, n, s) for n, (p, s) in lay.stages.items()})
                    res[label] = run_layout(lay, comps, cfg.steps, h)
                finally:
                    for c in comps.values():
                        c.close()
            n = int(round(window_s / h))
            rng = lambda y: float(np.ptp(y[-n:]))  # noqa: E731
            a, b = res["one"], res["two"]
            rows.append((fm, h, "m12 force range [N]", rng(a["stage1.m12.force"]), rng(b["stage1.m12.force"])))
            rows.append((fm, h, "m34 force range [N]", rng(a["stage1.m34.force"]), rng(b["stage2.m12.force"])))
            tw = {k: ks * (r["{}.{}".format(*angles[k][0])] - r["{}.{}".format(*angles[k][1])]) for k, r in res.items()}
            rows.append((fm, h, "shaft torque range [N m]", rng(tw["one"]), rng(tw["two"])))
    return rows


@pytest.mark.slow
def test_one_gear_train_fmu_against_the_two_stage_bench_of_two_fmus(tmp_path):
    """docs/validation.md "Two-stage gearbox": at the finest communication step the split bench reproduces the
    one-FMU train's mesh force ranges within BENCH_TOLERANCE and its shaft torque range within 1 % of the static
    shaft torque; at 1e-4 s the splitting error shows (the table gives every value against the one FMU's at the
    finest step).
    ``pytest -m slow tests/test_gear_train.py -k bench -s`` prints the table."""
    rows = bench_comparison(tmp_path)
    ref = {(fm, q): a for fm, h, q, a, _ in rows if h == min(BENCH_STEPS)}
    print("\n| mesh frequency [Hz] | step [s] | quantity | one FMU (gear_train) | two FMUs + shaft |")
    print("|---|---|---|---|---|")
    for fm, h, q, a, b in rows:
        r = ref[(fm, q)]
        print(f"| {fm:g} | {h:g} | {q} | {a:.1f} ({100 * (a - r) / r:+.1f} %) | {b:.1f} ({100 * (b - r) / r:+.1f} %) |")
    static = 300.0  # the intermediate shaft's static torque [N m] (test_static_shaft_torque_...)
    for fm, h, q, a, b in rows:
        if h == min(BENCH_STEPS):
            assert abs(b - a) <= (BENCH_TOLERANCE * a if "force" in q else 0.01 * static), (fm, h, q, a, b)


def test_readme_lists_the_fmu_variables_of_the_spec():
    """models/gear_train_2stage/readme.md shows the coupling diagram and the variables its FMU declares
    (shaft2.torque included)."""
    from hacgear_core.fmu.adapter import make_adapter
    from hacgear_core.fmu.documentation import readme_block
    from hacgear_core.fmu.spec import readme_with_variables

    folder = resolve_model_path(SYSTEM).parent
    text = (folder / "readme.md").read_text(encoding="utf-8")
    assert "`shaft2.torque`" in text
    assert readme_with_variables(text, readme_block(make_adapter(folder))) == text, \
        f"run `python build_fmu.py --system {SYSTEM} --readme`"


def _three_stages() -> str:
    """gear_train_2stage with a third stage behind wheel2 (pinion3 -> wheel3, the gears of stage 1: pinion3 turns
    counter-clockwise with wheel2, so its drive flank is the 25 deg one) on a second shaft of 2e4 N m/rad."""
    txt = _text()
    i = txt.index('[[gears]]\nname = "pinion1"')
    j = txt.index('[[gears]]\nname = "pinion2"')
    stage1 = txt[i:j].replace('name = "pinion1"', 'name = "pinion3"').replace('name = "wheel1"', 'name = "wheel3"')
    k = txt.index("[[meshes]]")
    txt = txt[:k] + stage1 + txt[k:]
    return txt.replace("[damping]", '[[meshes]]\nname = "m56"\ngear_a = "pinion3"\ngear_b = "wheel3"\n'
                                    'center_distance_mm = 140.0\nline_of_centres_deg = 90.0\n\n'
                                    '[[gear_train.shafts]]\nname = "shaft3"\ngear_a = "wheel2"\ngear_b = "pinion3"\n'
                                    'torsional_stiffness_Nm_per_rad = 2.0e4\n\n[damping]')


def test_three_stages_in_series_equal_the_hand_written_matrices(model):
    """Any number of meshes in series: three stages (the third at right angles) on the two-stage model's tables;
    the modes equal scipy.linalg.eigh of the 6 x 6 M and K written here, both shafts carry 300 N m statically,
    the torque enters at pinion1 and leaves at wheel3 only."""
    from hacgear_core.dynamics.equilibrium import static_equilibrium
    from hacgear_core.dynamics.modes import modal_analysis

    tabs = load_system_tables(SYSTEM)
    tables = {"m12": tabs.mesh("m12"), "m34": tabs.mesh("m34"), "m56": tabs.mesh("m12")}
    three = parse_model(_three_stages())
    sy = build_system(three, tables)
    gears = ("pinion1", "wheel1", "pinion2", "wheel2", "pinion3", "wheel3")
    assert sy.dof_names == tuple(f"{g}.theta" for g in gears)
    rb = 5.0e-3 * 28 * math.cos(math.radians(25.0)) / 2
    K = np.zeros((6, 6))
    for k, (a, ks) in enumerate(((0, None), (2, 1.0e4), (4, 2.0e4))):
        v = np.zeros(6)
        v[[a, a + 1]] = rb
        K += sy.mesh_stiffness_N_per_m[k] * np.outer(v, v)
        if ks:
            s = np.zeros(6)
            s[[a - 1, a]] = 1.0, -1.0
            K += ks * np.outer(s, s)
    M = np.diag([gear_geometry(three.gear(g)).inertia_kgm2 for g in gears])
    w2 = scipy.linalg.eigh(K, M, eigvals_only=True)
    np.testing.assert_allclose(modal_analysis(sy).natural_frequencies_Hz, np.sqrt(w2[1:]) / (2 * math.pi), rtol=1e-9)
    fe = sy.fext_speed()
    assert [g for g in gears if fe[sy.dof_names.index(f"{g}.theta")] != 0] == ["pinion1", "wheel3"]
    q = static_equilibrium(sy, 0.25).q
    for a, b, ks in (("wheel1", "pinion2", 1.0e4), ("wheel2", "pinion3", 2.0e4)):
        ia, ib = sy.dof_names.index(f"{a}.theta"), sy.dof_names.index(f"{b}.theta")
        assert sy.gears[a].sense * ks * (q[ia] - q[ib]) == pytest.approx(300.0, rel=1e-9)
    np.testing.assert_allclose(sy.phase[:2], build_system(model, tabs).phase, atol=1e-15)


def test_info_and_stiffness_load_each_stage_with_the_torque_the_shafts_pass_on(capsys):
    """``info`` and ``stiffness`` ask the kind for the torque flow: the second stage carries the force the
    intermediate shaft passes on (1:1 stages: the first stage's T / r_b) and ``info`` prints the phases of the
    placed gear train (the second stage's from the mounting angle)."""
    model = load_model(resolve_model_path(SYSTEM))
    rb = gear_geometry(model.gear("pinion1")).base_radius_m[model.mesh("m12").flank_a]
    assert main(["info", SYSTEM, "--json"]) == 0
    info = json.loads(capsys.readouterr().out)["meshes"]
    placed = place_gear_train(model)
    for name in ("m12", "m34"):
        assert info[name]["nominal_force_N"] == pytest.approx(model.operating.torque_Nm / rb, rel=1e-12)
        assert info[name]["phase"] == pytest.approx(placed.meshes[name].phase, abs=1e-12)
    assert main(["stiffness", SYSTEM, "--torque", "150", "--positions", "4", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)["meshes"]
    assert report["m34"]["mesh_force_N"] == pytest.approx(150.0 / rb, rel=1e-12)
    assert report["m34"]["mean_mesh_stiffness_N_per_m"] == pytest.approx(
        report["m12"]["mean_mesh_stiffness_N_per_m"], rel=MIRROR_TOLERANCE)


def test_shaft_bending_to_a_helical_gear_is_the_gearboxs():
    """reducer_helical_19_71_23_83 (helical stage m12 placed at 40 deg, spur stage m34) with its intermediate shaft
    bent (k_b = 4e8 N/m, wheel1 helical in its pair's own frame, pinion2 spur): the gear_train builds the same M and
    K as the gearbox of the same stages (whose static centres balance their forces in the fixed frame:
    tests/test_gearbox.py), 1e-12; the shaft's spring joins wheel1's pair-frame x and y turned by 40 deg."""
    from hacgear_core.kinds import parse_model

    text = resolve_model_path("reducer_helical_19_71_23_83").read_text().replace(
        "torsional_stiffness_Nm_per_rad = 1.34e5", "torsional_stiffness_Nm_per_rad = 1.34e5\n"
        "bending_stiffness_N_per_m = 4.0e8").replace('gear_b = "wheel1"\n', 'gear_b = "wheel1"\nline_of_centres_deg = 40.0\n', 1)
    box = (text.replace('kind = "gear_train"', 'kind = "gearbox"').replace("[[gear_train.shafts]]", "[[gearbox.shafts]]")
           .replace('gear_a = "wheel1"\ngear_b = "pinion2"', 'member_a = "wheel1"\nmember_b = "pinion2"'))
    tables = load_system_tables("reducer_helical_19_71_23_83")
    st = build_system(parse_model(text, file="train.toml"), tables, shafts=False)
    sb = build_system(parse_model(box, file="box.toml"), tables, shafts=False)
    assert sorted(st.dof_names) == sorted(sb.dof_names)
    p = [list(sb.dof_names).index(n) for n in st.dof_names]
    for a, b in ((st.M, sb.M), (st.K, sb.K)):
        np.testing.assert_allclose(np.asarray(b)[np.ix_(p, p)], a, rtol=0, atol=1e-12 * np.max(np.abs(a)))
    i, j = st.dof_names.index("wheel1.x"), st.dof_names.index("pinion2.x")
    assert st.K[i, j] == pytest.approx(-4.0e8 * math.cos(math.radians(40.0)), rel=1e-9)

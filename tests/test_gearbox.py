"""kinds/gearbox.py: planetary and parallel stages in series (the NREL 5 MW reference gearbox as one system)."""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import scipy.linalg

from hacgear_core.dynamics import Simulator, static_equilibrium, steady_state
from hacgear_core.dynamics.modes import gyroscopic_modes
from hacgear_core.dynamics.steady import SteadyStateOptions, window_cycles
from hacgear_core.errors import ModelError
from hacgear_core.kinds import build_system, kind_of, load_model, parse_model
from hacgear_core.kinds.gearbox import gearbox_stages, mesh_rates
from hacgear_core.model import resolve_model_path
from hacgear_core.tables import load_system_tables

from _fmu_runs import adapter_and_library_forces, fmu_and_library_runs

GEARBOX = "nrel_5mw_gearbox"


@pytest.fixture(scope="module")
def model():
    return load_model(GEARBOX)


@pytest.fixture(scope="module")
def system(model):
    return build_system(model, load_system_tables(GEARBOX))


@pytest.fixture(scope="module")
def stage_systems():
    return {i: build_system(load_model(f"nrel_5mw_stage{i}"), load_system_tables(f"nrel_5mw_stage{i}"))
            for i in (1, 2)}


def test_stage_kinematics_are_exact(model):
    """Each stage's ratio from its tooth counts (Willis for the planetary stages), the overall ratio 96.354166...
    exact, and the rated mesh frequencies the issue quotes (11.29, 74.03, 466.35 Hz at 12.1 rpm)."""
    st = gearbox_stages(model)
    assert [s.name for s in st] == ["stage1", "stage2", "s3_wheel_pinion"]
    assert [(s.input, s.output) for s in st] == [("carrier1", "sun1"), ("carrier2", "sun2"), ("wheel3", "pinion3")]
    assert [s.speed_out / s.speed_in for s in st] == [Fraction(75, 19), Fraction(111, 18), Fraction(95, 24)]
    assert st[-1].speed_out == Fraction(4625, 48) and float(st[-1].speed_out) == pytest.approx(96.354166666, 1e-9)
    fm = [float(s.mesh_frequency) * 12.1 / 60 for s in st]
    assert fm == pytest.approx([11.29, 74.03, 466.35], abs=5e-3)
    assert mesh_rates(model)["s3_wheel_pinion"] == (4625, 112)
    assert mesh_rates(model)["s2_ring_planet"] == (6975, 1064)


def test_system_period_and_window(system):
    """The rates' common period is 2128 reference cycles (38 input revolutions); the observation window is one
    revolution of the slowest shaft (the input carrier: 56 reference cycles)."""
    assert system.period_cycles == 2128
    assert window_cycles(system) == 56
    assert window_cycles(system, 3) == 168


def test_static_torques_follow_the_ratios(model, system):
    """Static equilibrium at the rated torque: each shaft carries the input torque times its stage ratios (1e-9),
    the issue's 999 650.88 / 162 105.55 / 40 952.98 N m within the rounding of the input torque (1e-6)."""
    eq = static_equilibrium(system)
    assert eq.success
    sim = Simulator(system)
    sim.s[:system.n] = eq.q
    out = {e.name: e.read(sim) for e in kind_of(model).extra_outputs(model, system)}
    t = model.operating.torque_Nm
    assert out["ims_shaft.torque"] == pytest.approx(t * 19 / 75, rel=1e-9)
    assert out["hs_ims_shaft.torque"] == pytest.approx(t * 19 / 75 * 18 / 111, rel=1e-9)
    assert out["ims_shaft.torque"] == pytest.approx(999650.88, rel=1e-6)
    assert out["hs_ims_shaft.torque"] == pytest.approx(162105.55, rel=1e-6)
    # the generator side: the helical mesh carries the high-speed shaft's torque; the pinion's, T * 48 / 4625
    k3 = system.mesh_names.index("s3_wheel_pinion")
    assert eq.mesh_forces_N[k3] == pytest.approx(system.meshes[k3].nominal_force_N, rel=2e-3)
    assert t * 48 / 4625 == pytest.approx(40952.98, rel=1e-6)
    # every planet of a stage carries its share of the stage torque
    for stage in ("s1_sun_planet", "s2_ring_planet"):
        idx = [k for k, c in enumerate(system.meshes) if c.group == stage]
        assert len(idx) == 3
        assert eq.mesh_forces_N[idx] == pytest.approx(system.meshes[idx[0]].nominal_force_N, rel=2e-3)


def test_each_planetary_stage_turns_in_its_own_frame(model, system, stage_systems):
    """G and K_W: stage s's blocks are its own planetary model's (models/nrel_5mw_stage<s>, the same DOFs) at its
    carrier speed, c_s = (its carrier ratio) x (its input speed over the gearbox's), exact from the tooth counts;
    the helical stage has none; each body's bearing force turns with its stage's frame."""
    names = system.dof_names
    speed_in = {i + 1: float(s.speed_in) for i, s in enumerate(gearbox_stages(model)[:2])}
    for i, sub in stage_systems.items():
        c = sub.carrier_ratio * speed_in[i]
        ren = {"carrier": f"carrier{i}", "sun": f"sun{i}", "ring": f"ring{i}"}
        ren.update({f"planet_{k}": f"planet{i}_{k}" for k in (1, 2, 3)})
        idx = [names.index(f"{ren[d.rsplit('.', 1)[0]]}.{d.rsplit('.', 1)[1]}") for d in sub.dof_names]
        np.testing.assert_allclose(system.G[np.ix_(idx, idx)], c * sub.G, rtol=1e-12, atol=0)
        np.testing.assert_allclose(system.K_W[np.ix_(idx, idx)], c * c * sub.K_W, rtol=1e-12, atol=0)
        assert abs(c) == pytest.approx(1.0 if i == 1 else 75 / 19, rel=1e-12)
        for body in (f"carrier{i}", f"sun{i}", f"planet{i}_2"):
            assert system.frame_ratio(body) == pytest.approx(c, rel=1e-12)
    n3 = [k for k, d in enumerate(names) if d.startswith(("wheel3", "pinion3"))]
    assert not np.any(system.G[n3]) and not np.any(system.K_W[n3])
    assert system.frame_ratio("wheel3") == 0.0 and system.carrier_ratio == 1.0


def _independent_modes(M, K, G, w):
    """Natural frequencies [Hz] of M q'' + w G q' + K q = 0 from the first-order companion form (written here,
    independently of hacgear_core.dynamics.modes)."""
    n = M.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -w * np.linalg.solve(M, G)]])
    lam = scipy.linalg.eigvals(a)
    f = np.sort(np.abs(lam.imag[lam.imag > 1e-6])) / (2 * math.pi)
    return f


@pytest.mark.parametrize("speed_rad_s", [0.0, 12.1 * 2 * math.pi / 60])
def test_modes_equal_an_independent_eigensolution(system, speed_rad_s):
    """The gyroscopic modes at rest and at rated input speed equal the eigen-solution of the same M, K, G, K_W
    computed here (relative 1e-8); every mode is labelled with its stage and member."""
    gm = gyroscopic_modes(system, speed_rad_s)
    keff = system.k_lin - speed_rad_s ** 2 * system.K_W
    if speed_rad_s == 0.0:
        ref = np.sqrt(np.clip(scipy.linalg.eigh(keff, system.M, eigvals_only=True), 0, None)) / (2 * math.pi)
        ref = np.sort(ref[ref > 1e-3])
    else:
        ref = _independent_modes(system.M, keff, system.G, speed_rad_s)
    ours = np.sort(gm.natural_frequencies_Hz[gm.natural_frequencies_Hz > 1e-3])
    assert len(ours) == len(ref) == system.n
    np.testing.assert_allclose(ours, ref, rtol=1e-8)
    stages = {d[0] for d in gm.dominant}
    assert stages == {"stage1", "stage2", "s3_wheel_pinion"}
    assert all(0 < d[2] <= 1 for d in gm.dominant)


def test_refusals_name_the_key():
    text = resolve_model_path(GEARBOX).read_text()
    cases = [
        (text.replace('member_b = "carrier2"', 'member_b = "carrier9"'), "gearbox.shafts 'ims_shaft'.member_b"),
        (text.replace('member_b = "carrier2"', 'member_b = "planet1"'), "joins two members of one stage"),
        (text.replace('output_member = "pinion3"', 'output_member = "sun1"'), "not a member of the last stage"),
        (text.replace("  rotational_stiffness_Nm_per_rad = 0.0   # turns on its shaft to the next stage's carrier",
                      "  rotational_stiffness_Nm_per_rad = 5.0e6", 1), "must be 0 for a turning member"),
        (text.replace('sun = "sun2"', 'sun = "sun1"'), "name the same set"),
        (text.replace('member_a = "sun2"', 'member_a = "sun1"'), "all leave one stage"),
        (text.replace("torsional_stiffness_Nm_per_rad = 1.25555e9", "torsional_stiffness_Nm_per_rad = 1.25555e9\n"
                      "bending_stiffness_N_per_m = -1"), "bending_stiffness_N_per_m' [N/m]: value -1 out of range"),
    ]
    for bad, words in cases:
        with pytest.raises(ModelError, match=None) as exc:
            parse_model(bad, file="gearbox.toml")
        assert words in str(exc.value), (words, str(exc.value))


@pytest.mark.slow
def test_quasi_periodic_steady_state_at_rated_speed(system):
    """At rated speed the response settles: two windows of one input revolution agree within 1 %, the mean mesh
    forces equal the static ones within 0.1 %, no contact loss."""
    r = steady_state(system, 56 * 12.1 / 60, options=SteadyStateOptions())
    assert r.status == "quasi-periodic" and r.period_cycles == 56
    m = r.metrics
    assert np.all(m["contact_loss_fraction"] == 0)
    assert np.all(m["dynamic_factor_force"] > 1.0) and np.all(m["dynamic_factor_force"] < 1.3)


def test_drivetrain_coupling_frees_the_ports_and_keeps_the_rings_held(model):
    """shafts=False: carrier1 and pinion3 are free torque ports (the train turns freely), every ring stays held
    (a planetary stage's fixed member is found by its role whatever its gear is called)."""
    sy = build_system(model, load_system_tables(GEARBOX), shafts=False)
    assert sy.rigid_mode is not None
    assert sy.gears["ring1"].rotation == -1 and sy.gears["ring2"].rotation == -1
    assert sy.gears["pinion3"].rotation >= 0 and sy.gears["carrier1"].rotation >= 0
    held = build_system(model, load_system_tables(GEARBOX))
    assert held.rigid_mode is None and held.gears["pinion3"].rotation == -1


@pytest.mark.slow
def test_fmu_equals_the_library(tmp_path):
    """The native FMI 2.0 FMU against the library's Simulator at rated input speed, step for step (1e-9): a mesh
    force of each stage, the high-speed mesh's position and both shaft torques."""
    pytest.importorskip("fmpy")
    speed = 12.1 * 2 * math.pi / 60
    names = ["s1_sun_planet_1.force", "s2_ring_planet_2.force", "s3_wheel_pinion.force", "s3_wheel_pinion.position",
             "ims_shaft.torque", "hs_ims_shaft.torque"]
    model = load_model(GEARBOX)

    def read(sim):
        sy = sim.system
        out = {e.name: e.read(sim) for e in kind_of(model).extra_outputs(model, sy)}
        k = [sy.mesh_names.index(n.rsplit(".", 1)[0]) for n in names[:4]]
        return (sim.mesh_force_N[k[0]], sim.mesh_force_N[k[1]], sim.mesh_force_N[k[2]], sim.mesh_position[k[3]],
                out["ims_shaft.torque"], out["hs_ims_shaft.torque"])
    _, res, lib = fmu_and_library_runs(GEARBOX, tmp_path, names, read, speed, 50, port="carrier1")
    for k in names:
        v = np.asarray(lib[k])
        assert np.max(np.abs(res[k][1:] - v)) <= 1e-9 * np.max(np.abs(v)), k


@pytest.mark.slow
def test_sweep_reports_every_stage_at_its_mesh_frequency(capsys):
    """`hacgear sweep nrel_5mw_gearbox --fm 9:11:2 --json`: each speed settles (quasi-periodic, one input revolution
    per window) and each mesh's record carries its own mesh frequency, rate x the input mesh frequency."""
    import json

    from hacgear_core.cli import main

    assert main(["sweep", GEARBOX, "--fm", "9:11:2", "--direction", "up", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    b = out["branches"]["up"]
    assert all(b["converged"]) and b["period_cycles"] == [56, 56]
    for mesh, rate in (("s1_ring_planet_2", 1.0), ("s2_sun_planet_3", 6975 / 1064), ("s3_wheel_pinion", 4625 / 112)):
        assert b["meshes"][mesh]["mesh_frequency_Hz"] == pytest.approx([9.0 * rate, 11.0 * rate], rel=1e-12)
        assert all(1.0 < f < 1.3 for f in b["meshes"][mesh]["dynamic_factor_force"])


def _reducer_texts(bending_N_per_m: float) -> tuple[str, str]:
    """The two-stage reducer's model file as a gear_train and as a gearbox, its intermediate shaft with the given
    bending stiffness [N/m]."""
    text = resolve_model_path("reducer_19_71_23_83").read_text().replace(
        "torsional_stiffness_Nm_per_rad = 1.34e5",
        f"torsional_stiffness_Nm_per_rad = 1.34e5\nbending_stiffness_N_per_m = {bending_N_per_m!r}")
    box = (text.replace('kind = "gear_train"', 'kind = "gearbox"').replace("[[gear_train.shafts]]", "[[gearbox.shafts]]")
           .replace('gear_a = "wheel1"\ngear_b = "pinion2"', 'member_a = "wheel1"\nmember_b = "pinion2"'))
    assert box.count("member_a") == 1
    return text, box


def test_shaft_bending_between_parallel_stages_equals_the_gear_trains():
    """A gearbox of two parallel spur stages joined by a shaft with bending stiffness has the gear_train's M, K and
    mesh vectors (which join the two gears' x and y in one frame), and the bending spring moves its modes."""
    tables = load_system_tables("reducer_19_71_23_83")
    kb = 3.0e8
    as_train, as_box = (parse_model(t, file=f) for t, f in zip(_reducer_texts(kb), ("train.toml", "box.toml")))
    st = build_system(as_train, tables, shafts=False)
    sb = build_system(as_box, tables, shafts=False)
    assert sorted(st.dof_names) == sorted(sb.dof_names)
    assert {"wheel1.x", "wheel1.y", "pinion2.x", "pinion2.y"} <= set(sb.dof_names)
    p = [list(sb.dof_names).index(n) for n in st.dof_names]
    for a, b in ((st.M, sb.M), (st.K, sb.K)):
        np.testing.assert_allclose(np.asarray(b)[np.ix_(p, p)], a, rtol=0, atol=1e-12 * np.max(np.abs(a)))
    np.testing.assert_allclose(np.asarray(sb.V)[:, p], st.V, rtol=0, atol=1e-12)
    i, j = list(sb.dof_names).index("wheel1.x"), list(sb.dof_names).index("pinion2.x")
    assert np.asarray(sb.K)[i, j] == pytest.approx(-kb, rel=1e-12)
    free = build_system(parse_model(_reducer_texts(0.0)[1], file="free.toml"), tables, shafts=False)
    f_bent, f_free = sb.natural_frequencies_Hz(), free.natural_frequencies_Hz()
    assert len(f_bent) == len(f_free) + 2    # x and y of each intermediate gear instead of its line of action
    assert f_bent[2] > 1.05 * f_free[2]      # the shaft stiffens the intermediate gears' translation
    # the constant-speed experiment (output held) builds with the same springs
    held = build_system(as_box, tables)
    assert held.n == sb.n - 1


def _bent_ims_shaft(k_b: float):
    """The NREL gearbox with a bending stiffness ``k_b`` [N/m] on its intermediate shaft (sun1 in stage 1's
    carrier frame to carrier2 in stage 2's), and without."""
    text = resolve_model_path(GEARBOX).read_text()
    tables = load_system_tables(GEARBOX)
    bent = text.replace("torsional_stiffness_Nm_per_rad = 1.25555e9",
                        f"torsional_stiffness_Nm_per_rad = 1.25555e9\nbending_stiffness_N_per_m = {k_b!r}")
    return build_system(parse_model(bent, file="bent.toml"), tables), build_system(parse_model(text, file="b.toml"),
                                                                                   tables)


def test_shaft_bending_across_turning_frames_is_the_fixed_frame_spring():
    """A bending spring between members of stages whose carriers turn at different speeds: at every reference
    position its energy is k_b/2 |R(phi_a) u_a - R(phi_b) u_b|^2, written here in the fixed frame with each
    frame's angle phi = c_s theta from the stage's carrier speed; it repeats after one relative revolution of the
    frames (19 reference mesh cycles: 56/19 input revolutions' worth of the carriers' speed difference); the
    frozen modes do not depend on the frames' angle (the three-planet stages are isotropic: 1e-9)."""
    k_b = 2.0e9
    sy, plain = _bent_ims_shaft(k_b)
    assert [(f.name, f.rate) for f in sy.frame_couplings] == [("ims_shaft", (-1, 19))]
    assert sy.period_cycles == plain.period_cycles == 2128
    a, b = sy.gears["sun1"], sy.gears["carrier2"]
    assert (a.frame_ratio, b.frame_ratio) == pytest.approx((-1.0, -75 / 19), rel=1e-12)
    rng = np.random.default_rng(5)
    for c in (0.0, 3.7, 11.25, 19.0, 1000.3, 123456.789):
        q = rng.normal(size=sy.n) * 1e-4
        theta = c / sy.zref_2pi                     # input rotation [rad]
        u = []
        for g in (a, b):
            phi = g.frame_ratio * theta
            rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
            u.append(rot @ (g.directions.T @ q[list(g.translations)]))
        hand = 0.5 * k_b * float(np.sum((u[0] - u[1]) ** 2))
        e = 0.5 * q @ (sy.stiffness_at(c) - plain.K) @ q
        assert e == pytest.approx(hand, rel=1e-9, abs=1e-9 * k_b * 1e-8), c
    np.testing.assert_allclose(sy.stiffness_at(19.0), sy.K, rtol=0, atol=1e-6 * k_b)
    assert not np.allclose(sy.stiffness_at(4.75), sy.K, atol=1e-3 * k_b)
    f0 = sy.natural_frequencies_Hz()
    for c in (4.75, 9.5, 13.0):
        fc = sy.with_changes(stiffness=sy.stiffness_at(c), frame_couplings=()).natural_frequencies_Hz()
        np.testing.assert_allclose(fc, f0, rtol=1e-9)
    # the bent shaft stiffens the sun's whirl: the 48.0 Hz pair of the free-floating sun moves up
    assert np.min(np.abs(f0 - 48.04)) > 1.0 and np.min(np.abs(plain.natural_frequencies_Hz() - 48.04)) < 0.01


def test_shaft_bending_across_turning_frames_runs_in_the_kernel():
    """The bent intermediate shaft in a run of 0.2 s at rated speed (the generic twist loop with the frame
    coupling; the frames turn 0.74 rad against each other): the run stays on its tables and every mesh carries its
    nominal force on average (5 %)."""
    sy, _ = _bent_ims_shaft(2.0e9)
    eq = static_equilibrium(sy)
    assert eq.success
    sim = Simulator(sy)
    sim.set_speed_input(mesh_frequency_Hz=12.1 / 60 * 56)
    sim.s[:sy.n] = eq.q
    out = sim.run(0.2, 1e-3)
    assert np.all(np.isfinite(out["state"])) and not np.any(sim.kin[3:])
    f = out["mesh_force_N"]
    for k, c in enumerate(sy.meshes):
        assert np.mean(f[-50:, k]) == pytest.approx(c.nominal_force_N, rel=0.05), c.name


def test_bending_on_the_nrel_high_speed_intermediate_shaft_is_refused_as_a_mirror_image():
    """The NREL model's stage 3 turns wheel3 counter-clockwise where stage 2 turns sun2 clockwise (each stage's
    sense from its own flanks; the torsion joins them by magnitude): a bending stiffness on that shaft is refused
    at build, naming the shaft and both members' senses."""
    text = resolve_model_path(GEARBOX).read_text().replace(
        "torsional_stiffness_Nm_per_rad = 1.43614e8", "torsional_stiffness_Nm_per_rad = 1.43614e8\n"
        "bending_stiffness_N_per_m = 1e9")
    with pytest.raises(ModelError) as exc:
        build_system(parse_model(text, file="gearbox.toml"), load_system_tables(GEARBOX))
    msg = str(exc.value)
    for words in ("gearbox.shafts 'hs_ims_shaft'.bending_stiffness_N_per_m [N/m]", "'sun2' turns clockwise",
                  "'wheel3' counter-clockwise", "mirror image"):
        assert words in msg, msg


def test_bending_between_stages_built_as_mirror_images_is_refused():
    """The reducer's second stage on its drive flanks turns pinion2 counter-clockwise while wheel1 turns clockwise
    on the same shaft (the torsion joins them by magnitude): the stage is a mirror image, its x and y are not the
    first stage's, so a bending spring between them is refused, naming the shaft, both members and their senses."""
    _, box = _reducer_texts(3e8)
    flanks = 'flank_a = "coast"                  # pinion2 turns clockwise with wheel1: the flanks on that side ' \
             '(symmetric teeth)\nflank_b = "coast"'
    assert flanks in box
    mirrored = box.replace(flanks, 'flank_a = "drive"\nflank_b = "drive"')
    tables = load_system_tables("reducer_19_71_23_83")
    with pytest.raises(ModelError) as exc:
        build_system(parse_model(mirrored, file="box.toml"), tables, shafts=False)
    msg = str(exc.value)
    for words in ("gearbox.shafts 'shaft2'.bending_stiffness_N_per_m [N/m]", "'wheel1' turns clockwise",
                  "'pinion2' counter-clockwise", "mirror image"):
        assert words in msg, msg
    # without the bending spring the mirrored stage is a valid gearbox (the torsion joins the magnitudes)
    build_system(parse_model(_reducer_texts(0.0)[1].replace(flanks, 'flank_a = "drive"\nflank_b = "drive"'),
                             file="box.toml"), tables, shafts=False)


def test_fmu_adapter_runs_the_bent_shaft_system(tmp_path):
    """The FMUs' adapter (in process) of the NREL gearbox with its intermediate shaft bent (a model folder of its
    own with a copy of the shipped tables) builds the library's system, frame coupling included (equal fingerprints), and
    a 40-step run of 20 us gives the library simulator's mesh forces exactly."""
    import shutil
    import hacgear_core.fmu as hf

    src = resolve_model_path(GEARBOX).parent
    (tmp_path / "model.toml").write_text((src / "model.toml").read_text().replace(
        "torsional_stiffness_Nm_per_rad = 1.25555e9",
        "torsional_stiffness_Nm_per_rad = 1.25555e9\nbending_stiffness_N_per_m = 2.0e9"))
    shutil.copyfile(src / "tables.h5", tmp_path / "tables.h5")
    ad = hf.make_adapter(tmp_path)
    ad.configure({v.name: v.start for v in ad.variables if v.causality in ("parameter", "input")})
    ref, _ = _bent_ims_shaft(2.0e9)
    assert [f.name for f in ad.sim.system.frame_couplings] == ["ims_shaft"]
    assert ad.sim.system.fingerprint() == ref.fingerprint()
    ours, lib = adapter_and_library_forces(ad, ref)
    assert np.ptp(lib) > 0.0 and np.array_equal(ours, lib)


@pytest.mark.parametrize("line_of_centres_deg", [0.0, 40.0])
def test_shaft_bending_to_a_helical_gear_balances_the_forces_in_the_fixed_frame(line_of_centres_deg):
    """reducer_helical_19_71_23_83 as a gearbox (helical stage m12, spur stage m34) with its intermediate shaft bent
    (k_b = 4e8 N/m) from the helical wheel1 (translations in its pair's own frame) to the spur pinion2 (in the fixed
    frame), stage m12 placed at 0 and at 40 deg: at the static equilibrium the two centres balance their mesh
    forces, bearings and the shaft in the fixed frame, so pinion2's centre [m] is the closed form of two isotropic
    springs joined by a third, ((k_B + k_b) F_A + k_b F_B) / ((k_A + k_b)(k_B + k_b) - k_b^2), with F_A the m34
    force on pinion2 and F_B the in-plane part of the m12 force on wheel1, each along its mesh's line of action as
    the geometry places it (``train_geometry``), 1e-9."""
    from hacgear_core.geometry import train_geometry
    from hacgear_core.kinds.gearbox import _fixed_axis_model

    text = resolve_model_path("reducer_helical_19_71_23_83").read_text()
    box = (text.replace('kind = "gear_train"', 'kind = "gearbox"').replace("[[gear_train.shafts]]", "[[gearbox.shafts]]")
           .replace('gear_a = "wheel1"\ngear_b = "pinion2"', 'member_a = "wheel1"\nmember_b = "pinion2"')
           .replace("torsional_stiffness_Nm_per_rad = 1.34e5",
                    "torsional_stiffness_Nm_per_rad = 1.34e5\nbending_stiffness_N_per_m = 4.0e8"))
    box = box.replace('gear_b = "wheel1"\n', f'gear_b = "wheel1"\nline_of_centres_deg = {line_of_centres_deg}\n', 1)
    model = parse_model(box, file="box.toml")
    sy = build_system(model, load_system_tables("reducer_helical_19_71_23_83"))
    eq = static_equilibrium(sy)
    assert eq.success
    loa = {}
    for st in gearbox_stages(model):
        placed = train_geometry(_fixed_axis_model(model, st))
        loa.update({m: np.asarray(placed.meshes[m].line_of_action, float) for m in st.meshes})
    assert math.degrees(math.atan2(loa["m12"][1], loa["m12"][0])) == pytest.approx(
        69.35 + line_of_centres_deg, abs=0.01)
    k12, k34 = sy.mesh_names.index("m12"), sy.mesh_names.index("m34")
    n_ref = np.asarray(sy.meshes[k12].table.twist.frame["n_ref"], float)
    f_b = eq.mesh_forces_N[k12] * float(np.linalg.norm(n_ref[:2])) * loa["m12"]   # gear_a pushes gear_b (wheel1)
    f_a = -eq.mesh_forces_N[k34] * loa["m34"]                                       # the reaction on gear_a (pinion2)
    k_a, k_b, kk = sy.gears["pinion2"].support[0], sy.gears["wheel1"].support[0], 4.0e8
    u_a = ((k_b + kk) * f_a + kk * f_b) / ((k_a + kk) * (k_b + kk) - kk * kk)
    q = eq.q
    ours = np.array([q[sy.dof_names.index("pinion2.x")], q[sy.dof_names.index("pinion2.y")]])
    np.testing.assert_allclose(ours, u_a, rtol=1e-9, atol=1e-9 * float(np.max(np.abs(u_a))))
    assert float(np.max(np.abs(u_a))) > 1e-7

"""tables.h5: schema and provenance, model-hash refusal, interpolation policy (nodes, monotonicity,
periodicity, extrapolation counting), numba kernel, round trip."""
from __future__ import annotations

import hashlib
import math
import pickle
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from hacgear_core.errors import TableError
from hacgear_core.statics import AnalyticFactory, compute_statics, load_grid, run_statics
from hacgear_core.kinds import load_model
from hacgear_core.statics.helical import make_helical_solver
from hacgear_core.tables.fdf import generalized_stiffness
from hacgear_core.tables.interp import bilinear_many
from hacgear_core.tables import (
    DATASETS,
    FORMAT,
    FORMAT_VERSION,
    MeshTable,
    load_system_tables,
    read_tables,
    write_tables,
)

REPO = Path(__file__).resolve().parent.parent
MODEL = REPO / "models" / "spur_28t_asym" / "model.toml"
F_NOM = 300.0 / (0.07 * math.cos(math.radians(25.0)))
NP, NL, ND = 24, 8, 40


@pytest.fixture(scope="module")
def h5(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("tables") / "tables.h5"
    run_statics({"m12": AnalyticFactory()}, out, n_positions=NP, n_deflections=ND,
                loads_N={"m12": load_grid(3 * F_NOM, NL)}, workers=1, progress=False, model_sha256="0" * 64,
                model_file="model.toml")
    return out


@pytest.fixture(scope="module")
def table(h5) -> MeshTable:
    return read_tables(h5).mesh("m12")


@pytest.fixture(scope="module")
def model_run(tmp_path_factory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("model")
    shutil.copy(MODEL, d / "model.toml")
    compute_statics(d / "model.toml", positions=8, loads=4, deflections=8, solver="analytic", workers=1,
                    progress=False)
    return d / "model.toml", d / "tables.h5"


# ----------------------------------------------------------------------------------------------
# schema
# ----------------------------------------------------------------------------------------------
def test_root_attributes(h5):
    with h5py.File(h5, "r") as f:
        a = f.attrs
        assert a["format"] == FORMAT and a["format_version"] == FORMAT_VERSION
        assert a["model_sha256"] == "0" * 64 and a["hacgear_version"]
        assert len(a["created"]) >= 19 and a["created"].endswith("+00:00")
        assert (a["n_positions"], a["n_loads"], a["n_deflections"], a["n_meshes"]) == (NP, NL, ND, 1)
        assert list(a["mesh_names"]) == ["m12"]


EXPECTED_UNITS = {
    "position": "1", "load_N": "N", "deflection_m": "m", "no_load_deflection_m": "m", "static_deflection_m": "m",
    "force_N": "N", "tooth_offsets": "1", "tooth_load_N": "N", "contact_roll_deg": "deg", "half_width_m": "m",
    "peak_pressure_Pa": "Pa", "flank_pressure_Pa": "Pa", "edge_pressure_Pa": "Pa", "done_loads": "1",
    "done_deflections": "1",
}


def test_every_dataset_has_unit_description_and_shape(h5):
    nw = 5
    shapes = {
        "position": (NP,), "load_N": (NL,), "deflection_m": (ND,), "no_load_deflection_m": (NP,),
        "static_deflection_m": (NP, NL), "force_N": (NP, ND), "tooth_offsets": (nw,), "tooth_load_N": (NP, ND, nw),
        "contact_roll_deg": (NP, ND, nw), "half_width_m": (NP, ND, nw), "peak_pressure_Pa": (NP, ND),
        "flank_pressure_Pa": (NP, ND), "edge_pressure_Pa": (NP, ND), "done_loads": (NP,), "done_deflections": (NP,),
    }
    seen = []
    with h5py.File(h5, "r") as f:
        g = f["meshes/m12"]
        assert tuple(g.attrs["gear_names"]) == ("pinion", "wheel") and tuple(g.attrs["teeth"]) == (28, 28)

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                seen.append(name)
                assert obj.attrs["description"], name
                head = name.split("/")[0]
                unit = EXPECTED_UNITS.get(name, {"strain": "1", "hub_reaction": "N, N, N*m"}.get(head))
                assert obj.attrs["unit"] == unit, name
                if name in shapes:
                    assert obj.shape == shapes[name], name
                elif head == "strain":
                    assert obj.shape == (NP, ND, nw)
                else:
                    assert obj.shape == (NP, ND, 3)
        g.visititems(visit)
    assert set(shapes) <= set(seen)
    assert {"strain/pinion/SG25", "strain/wheel/SG25", "strain/wheel/SG20", "hub_reaction/pinion",
            "hub_reaction/wheel"} <= set(seen)
    assert set(DATASETS) >= {n.split("/")[0] for n in seen}


def test_contract_fields_and_kernel_arrays(table):
    assert table.position.shape == (NP,) and np.array_equal(table.position, np.arange(NP) / NP)
    assert table.force_N.flags.c_contiguous and table.force_N.dtype == np.float64
    assert (table.n_positions, table.n_deflections) == (NP, ND)
    assert table.x0_m == table.deflection_m[0]
    assert table.inv_dx == pytest.approx(1.0 / (table.deflection_m[1] - table.deflection_m[0]))
    # zero force at and below the NLMD, at every grid position
    below = table.deflection_m[None, :] <= table.no_load_deflection_m[:, None]
    assert np.all(table.force_N[below] == 0) and np.all(table.force_N[:, 0] == 0)
    np.testing.assert_allclose(table.tooth_load_N.sum(axis=2), table.force_N, rtol=1e-10, atol=1e-6)
    assert np.all(np.isnan(table.contact_roll_deg[table.tooth_load_N == 0]))
    # the static load-control results lie on the FDF (same solver, both directions)
    for i in range(NP):
        rec = np.interp(table.static_deflection_m[i], table.deflection_m, table.force_N[i])
        assert np.max(np.abs(rec - table.load_N)) < 0.02 * table.load_N[-1]
    np.testing.assert_array_equal(table.static_deflection_m[:, 0], table.no_load_deflection_m)


# ----------------------------------------------------------------------------------------------
# provenance / refusal
# ----------------------------------------------------------------------------------------------
def _edit(model: Path, dest: Path, old: str, new: str) -> Path:
    text = model.read_text()
    assert old in text, old
    dest.write_text(text.replace(old, new, 1))
    return dest


@pytest.mark.parametrize("old, new", [
    ("[system]", "# a comment\n[system]"),
    ("modal_damping_ratio = 0.02", "modal_damping_ratio = 0.05"),
    ("torque_Nm = 300.0", "torque_Nm = 250.0"),
    ("rotational_stiffness_Nm_per_rad = 0.0", "rotational_stiffness_Nm_per_rad = 1e6"),
    ('title = "', 'title = "edited: '),
])
def test_edits_the_tables_do_not_depend_on_keep_them_valid(model_run, tmp_path, old, new):
    model, tables = model_run
    changed = _edit(model, tmp_path / "model.toml", old, new)
    assert changed.read_bytes() != model.read_bytes()
    t = read_tables(tables, changed)
    assert t.attrs["model_values_sha256"] and t.model_sha256 == hashlib.sha256(model.read_bytes()).hexdigest()


@pytest.mark.parametrize("old, new, named", [
    ("tooth_thickness_mm = 7.64", "tooth_thickness_mm = 7.60", "gears.pinion.tooth_thickness_m: 0.00764 in the "
                                                               "table, 0.0076 now"),
    ("youngs_modulus_GPa = 201.5", "youngs_modulus_GPa = 210.0", "material.youngs_modulus_Pa"),
    ("radius_mm = 64.051", "radius_mm = 64.5", "gauges[0].radius_m"),
    ("center_distance_mm = 140.0", "center_distance_mm = 140.1", "meshes.m12.center_distance_m"),
    ("lead_crowning_um = 15.0", "lead_crowning_um = 0.0", "gears.pinion.lead_crowning_m: 1.4999999999999999e-05 "
                                                          "in the table, (default) now"),
])
def test_edits_of_values_the_tables_depend_on_are_refused_by_name(model_run, tmp_path, old, new, named):
    model, tables = model_run
    changed = _edit(model, tmp_path / "model.toml", old, new)
    with pytest.raises(TableError) as exc:
        read_tables(tables, changed)
    msg = str(exc.value)
    assert named in msg, msg
    assert str(tables) in msg and str(changed) in msg and f"hacgear statics {changed}" in msg
    assert "--ignore-model-hash" in msg
    t = read_tables(tables, model)
    t2 = read_tables(tables, changed, allow_hash_mismatch=True)
    np.testing.assert_array_equal(t2.mesh().force_N, t.mesh().force_N)


def test_statics_grid_is_part_of_the_provenance(model_run, tmp_path):
    model, tables = model_run
    changed = tmp_path / "model.toml"
    changed.write_text(model.read_text().replace("[statics]", "[statics]\nface_slices = 11", 1)
                       .replace("face_slices = 21", ""))
    with pytest.raises(TableError, match="statics.face_slices: .default. in the table, 11 now"):
        read_tables(tables, changed)


def test_old_tables_with_only_the_model_file_hash(model_run, tmp_path):
    """Tables written before value provenance hold only the hash of the model file's bytes: accepted while
    the file is byte-identical, refused with the regeneration command after any edit."""
    model, tables = model_run
    old = tmp_path / "old.h5"
    shutil.copy(tables, old)
    with h5py.File(old, "r+") as f:
        for k in ("model_values_sha256", "model_values", "attributes_sha256"):
            del f.attrs[k]
    assert read_tables(old, model).mesh().n_positions == 8
    changed = _edit(model, tmp_path / "model.toml", "[system]", "# a comment\n[system]")
    with pytest.raises(TableError, match=r"written before hacgear stored the model values.*hacgear statics"):
        read_tables(old, changed)


def test_cli_check_and_ignore_model_hash(model_run, tmp_path, capsys):
    from hacgear_core.cli import main

    model, tables = model_run
    assert main(["statics", str(model), "--check", "--json"]) == 0
    out = capsys.readouterr().out
    assert '"positions": 8' in out and '"problems": []' in out
    changed = _edit(model, tmp_path / "model.toml", "tooth_thickness_mm = 7.64", "tooth_thickness_mm = 7.6")
    assert main(["statics", str(changed), "--check", "--out", str(tables)]) == 2
    assert "does not belong" in capsys.readouterr().err
    assert main(["statics", str(changed), "--check", "--out", str(tables), "--ignore-model-hash"]) == 0
    assert "OK: checksums, provenance and physical sanity" in capsys.readouterr().out


# ----------------------------------------------------------------------------------------------
# integrity: checksums, attribute digest, physical sanity
# ----------------------------------------------------------------------------------------------
def _corrupt_bytes(path: Path, dataset: str, n: int = 24, seed: int = 0) -> None:
    """Overwrite ``n`` bytes of a dataset's first chunk in the file with random bytes (bypassing HDF5)."""
    with h5py.File(path, "r") as f:
        ds = f[dataset]
        info = ds.id.get_chunk_info(0)
        off, size = info.byte_offset, info.size
    rng = np.random.default_rng(seed)
    with open(path, "r+b") as fh:
        fh.seek(off + size // 3)
        fh.write(rng.integers(0, 256, n, dtype=np.uint8).tobytes())


def test_every_dataset_carries_a_checksum(h5):
    from hacgear_core.tables import file_integrity

    rep = file_integrity(h5)
    assert rep["datasets"] == rep["checksummed"] > 15 and not rep["unreadable"]
    assert rep["attributes"] == "verified"


def test_corrupted_bytes_are_refused_on_read_and_by_check(model_run, tmp_path, capsys):
    from hacgear_core.cli import main

    model, tables = model_run
    bad = tmp_path / "tables.h5"
    shutil.copy(tables, bad)
    _corrupt_bytes(bad, "meshes/m12/half_width_m")
    with pytest.raises(TableError, match=r"half_width_m fails its Fletcher-32 checksum.*corrupted"):
        read_tables(bad, model)
    assert main(["statics", str(model), "--check", "--out", str(bad)]) == 1
    out = capsys.readouterr().out
    assert "FAILED" in out and "half_width_m: Fletcher-32 checksum failed" in out


def test_corrupted_attributes_are_refused(model_run, tmp_path):
    model, tables = model_run
    bad = tmp_path / "tables.h5"
    shutil.copy(tables, bad)
    with h5py.File(bad, "r+") as f:
        f["meshes/m12"].attrs["base_radius_m"] = np.array([0.0634, 0.0700])
    with pytest.raises(TableError, match="attributes.*do not match their checksum"):
        read_tables(bad, model)


def test_absurd_force_is_refused_on_read_and_by_check(model_run, tmp_path, capsys):
    """A force of 8.7e299 N (written through HDF5, so its checksum is valid) is physically impossible."""
    from hacgear_core.cli import main

    model, tables = model_run
    bad = tmp_path / "tables.h5"
    shutil.copy(tables, bad)
    with h5py.File(bad, "r+") as f:
        f["meshes/m12/force_N"][3, 5] = 8.7e299
    with pytest.raises(TableError, match=r"force_N: value 8.7e\+299 N outside the plausible range"):
        read_tables(bad, model)
    assert main(["statics", str(model), "--check", "--out", str(bad)]) == 1
    assert "8.7e+299" in capsys.readouterr().out


@pytest.mark.parametrize("edit, expected", [
    (lambda f: f["meshes/m12/force_N"].__setitem__((2, -1), f["meshes/m12/force_N"][2, -2] * 0.9),
     "force_N: decreases"),
    (lambda f: f["meshes/m12/force_N"].__setitem__((2, 0), 10.0), "at or below the no-load mesh deflection"),
    (lambda f: f["meshes/m12/force_N"].__setitem__((2, 4), -5.0), "force_N: value -5 N outside"),
    (lambda f: f["meshes/m12/static_deflection_m"].__setitem__((1, 2), np.nan), "static_deflection_m: 1 non-finite"),
    (lambda f: f["meshes/m12/load_N"].__setitem__(1, f["meshes/m12/load_N"][1] * 1.5), "load_N: grid not regular"),
])
def test_check_finds_physically_wrong_tables(model_run, tmp_path, capsys, edit, expected):
    from hacgear_core.cli import main
    from hacgear_core.cli.statics import check_report

    model, tables = model_run
    bad = tmp_path / "tables.h5"
    shutil.copy(tables, bad)
    with h5py.File(bad, "r+") as f:
        edit(f)
    rep = check_report(model, bad)
    assert any(expected in q for q in rep["problems"]), rep["problems"]
    assert main(["statics", str(model), "--check", "--out", str(bad)]) == 1
    assert expected in capsys.readouterr().out


def test_check_reports_a_load_grid_short_of_the_model_torque(model_run, tmp_path):
    from hacgear_core.cli.statics import check_report

    model, tables = model_run
    hot = _edit(model, tmp_path / "model.toml", "torque_Nm = 300.0", "torque_Nm = 400.0")
    rep = check_report(hot, tables)
    assert any("2.25 x the model's nominal mesh force" in q for q in rep["problems"]), rep["problems"]


def test_incomplete_and_foreign_files_refused(h5, tmp_path):
    bad = tmp_path / "inc.h5"
    shutil.copy(h5, bad)
    with h5py.File(bad, "r+") as f:
        f["meshes/m12/done_deflections"][5] = 0
    with pytest.raises(TableError, match="incomplete.*`hacgear statics MODEL`"):
        read_tables(bad)
    assert read_tables(bad, allow_incomplete=True).mesh().n_positions == NP
    with h5py.File(bad, "r+") as f:
        f.attrs["format"] = "something-else"
    with pytest.raises(TableError, match="not a hacgear table"):
        read_tables(bad)
    (tmp_path / "junk.h5").write_bytes(b"not hdf5")
    with pytest.raises(TableError, match="not a readable HDF5"):
        read_tables(tmp_path / "junk.h5")
    with pytest.raises(TableError, match="not found"):
        read_tables(tmp_path / "missing.h5")


# ----------------------------------------------------------------------------------------------
# interpolation
# ----------------------------------------------------------------------------------------------
def test_exact_at_grid_nodes(table):
    P, X = np.meshgrid(table.position, table.deflection_m, indexing="ij")
    np.testing.assert_allclose(table.force(P, X), table.force_N, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(table.pressure(P, X), table.peak_pressure_Pa, rtol=1e-12, atol=1e-3)
    for k_idx, k in enumerate(table.tooth_offsets):
        for g in table.gauge_names:
            np.testing.assert_allclose(table.strain(g, P, X, tooth_offset=int(k)), table.strain[g][:, :, k_idx],
                                       rtol=1e-11, atol=1e-15)
        np.testing.assert_allclose(table.tooth_load(P, X, int(k)), table.tooth_load_N[:, :, k_idx],
                                   rtol=1e-11, atol=1e-9)
    np.testing.assert_allclose(table.no_load_deflection(table.position), table.no_load_deflection_m, atol=1e-20)
    np.testing.assert_allclose(table.static_deflection(table.position[:, None], table.load_N[None, :]),
                               table.static_deflection_m, rtol=1e-12)


def test_bilinear_between_nodes(table):
    i, j = 5, 20
    p = (i + 0.25) / NP
    x = table.deflection_m[j] + 0.5 * table.dx_m
    F = table.force_N
    expect = 0.75 * 0.5 * (F[i, j] + F[i, j + 1]) + 0.25 * 0.5 * (F[i + 1, j] + F[i + 1, j + 1])
    assert table.force(p, x) == pytest.approx(expect, rel=1e-12)


def test_force_monotone_non_decreasing_in_deflection(table):
    rng = np.random.default_rng(1)
    ps = rng.uniform(-2, 3, 50)
    xs = np.linspace(table.deflection_m[0] - 5e-6, table.deflection_m[-1] + 20e-6, 400)
    f = table.force(ps[:, None], xs[None, :])
    assert np.all(np.diff(f, axis=1) >= 0)
    assert np.all(np.diff(table.force_N, axis=1) >= 0)


def test_periodic_in_position(table):
    rng = np.random.default_rng(2)
    p = rng.uniform(0, 1, 200)
    x = rng.uniform(table.deflection_m[0], table.deflection_m[-1], 200)
    for n in (1, -1, 7, -13):
        np.testing.assert_allclose(table.force(p + n, x), table.force(p, x), rtol=1e-9, atol=1e-8)
        np.testing.assert_allclose(table.pressure(p + n, x), table.pressure(p, x), rtol=1e-9, atol=1e-3)
        np.testing.assert_allclose(table.no_load_deflection(p + n), table.no_load_deflection(p), atol=1e-18)
    # wrap-around cell between the last grid position and 1.0 interpolates towards position 0
    p_end = (NP - 0.5) / NP
    xm = table.deflection_m[25]
    assert table.force(p_end, xm) == pytest.approx(0.5 * (table.force_N[-1, 25] + table.force_N[0, 25]), rel=1e-12)
    # one tooth pair: X_k(p + 1) = X_{k-1}(p), including the wrap cell
    g = "wheel/SG25"
    pp = np.linspace(0, 0.999, 37)
    np.testing.assert_allclose(table.strain(g, pp + 1, xm, tooth_offset=1), table.strain(g, pp, xm, tooth_offset=0),
                               rtol=1e-9, atol=1e-15)
    # sum of per-pair loads reproduces the mesh force also between grid positions
    tot = sum(table.tooth_load(pp, xm, int(k)) for k in table.tooth_offsets[1:])  # k = -2 is unloaded
    np.testing.assert_allclose(tot, table.force(pp, xm), rtol=1e-9, atol=1e-6)


def test_sdf_outside_window_is_zero(table):
    """A tooth whose pair phase leaves the tabulated window is out of mesh: its strain is 0; NaN in gives NaN."""
    g = "pinion/SG25"
    x = table.deflection_m[30]
    assert table.sdf(g, -2.5, x) == 0.0 and table.sdf(g, 3.0 + 1e-9, x) == 0.0
    assert np.isnan(table.sdf(g, np.nan, x)) and np.isnan(table.sdf(g, 0.2, np.nan))
    tau = np.linspace(-2, 2.9, 99)
    assert np.all(np.isfinite(table.sdf(g, tau, x)))
    with pytest.raises(TableError, match="no gauge"):
        table.sdf("pinion/nope", 0.0, x)


def test_extrapolation_linear_counted_and_clipped(table):
    table.stats.reset()
    x_last, dx = table.deflection_m[-1], table.dx_m
    p = table.position[3]
    F = table.force_N[3]
    beyond = x_last + 2.5 * dx
    assert table.force(p, beyond) == pytest.approx(F[-1] + 2.5 * (F[-1] - F[-2]), rel=1e-12)
    assert table.force(p, table.deflection_m[0] - 3 * dx) == 0.0  # first two columns are zero
    table.force(np.full(10, p), np.linspace(0, x_last, 10))  # inside: not counted
    st = table.stats
    assert (st.n_queries, st.n_above, st.n_below) == (12, 1, 1)
    assert st.max_above_m == pytest.approx(2.5 * dx) and st.max_below_m == pytest.approx(3 * dx)
    assert "1 above the deflection grid" in st.report()
    table.force(p, np.nan)
    assert np.isnan(table.force(p, np.nan)) and st.n_queries == 12
    table.stats.reset()


def test_compiled_lookup_matches_the_table_queries(table):
    """The kernels' lookup (hacgear_core.tables.interp.bilinear, clipped at 0 as the force law does) and the
    table's vectorised queries are one interpolation."""
    rng = np.random.default_rng(3)
    ps = rng.uniform(-3, 3, 300)
    xs = rng.uniform(table.x0_m - 10e-6, table.deflection_m[-1] + 30e-6, 300)
    ref = table.force(ps, xs)
    got = np.empty(300)
    bilinear_many(table.force_N, table.x0_m, table.inv_dx, ps, xs, got)
    np.testing.assert_allclose(np.maximum(got, 0.0), ref, rtol=1e-12, atol=1e-9)


def test_write_read_round_trip_and_pickle(h5, tmp_path):
    t = read_tables(h5)
    out = tmp_path / "copy.h5"
    write_tables(out, t)
    t2 = read_tables(out)
    a, b = t.mesh(), t2.mesh()
    for k in ("position", "deflection_m", "force_N", "no_load_deflection_m", "load_N", "static_deflection_m",
              "tooth_offsets", "tooth_load_N", "contact_roll_deg", "peak_pressure_Pa", "half_width_m"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    for g in a.gauge_names:
        np.testing.assert_array_equal(a.strain[g], b.strain[g])
    assert t2.created == t.created and t2.model_sha256 == t.model_sha256
    c = pickle.loads(pickle.dumps(a))
    assert c.strain("wheel/SG25", 0.3, 40e-6) == pytest.approx(a.strain("wheel/SG25", 0.3, 40e-6))


def test_meshtable_validation_names_the_field(table):
    kw = {k: getattr(table, k) for k in ("name", "gear_names", "teeth", "base_radius_m", "position", "deflection_m",
                                         "force_N", "no_load_deflection_m", "load_N", "static_deflection_m",
                                         "tooth_offsets", "tooth_load_N", "contact_roll_deg", "peak_pressure_Pa")}
    kw["strain"] = dict(table.strain)
    with pytest.raises(TableError, match="force_N has shape"):
        MeshTable(**{**kw, "force_N": table.force_N[:, :-1]})
    with pytest.raises(TableError, match="deflection_m"):
        MeshTable(**{**kw, "deflection_m": table.deflection_m ** 2})
    with pytest.raises(TableError, match="position"):
        MeshTable(**{**kw, "position": table.position * 0.5})


# ----------------------------------------------------------------------------------------------
# two sides (coast subgroup), old one-sided files
# ----------------------------------------------------------------------------------------------
def test_coast_subgroup_layout_and_attributes(model_run):
    from hacgear_core.geometry import mesh_geometry
    from hacgear_core.kinds import load_model

    model, tables = model_run
    mg = mesh_geometry(load_model(model), "m12")
    with h5py.File(tables, "r") as f:
        assert list(f.attrs["mesh_names"]) == ["m12"] and f.attrs["n_meshes"] == 1
        d, c = f["meshes/m12"], f["meshes/m12/coast"]
        assert d.attrs["side"] == "drive" and tuple(d.attrs["flanks"]) == ()   # the analytic solver names none
        assert c.attrs["side"] == "coast"
        assert c.attrs["backlash_normal_m"] == mg.backlash_normal_m
        assert c.attrs["backlash_circular_m"] == mg.backlash_circular_m
        assert c.attrs["position_offset"] == mg.coast_position_offset
        assert list(c.attrs["pair_shift"]) == [1, 0] and list(c.attrs["gear_names"]) == ["pinion", "wheel"]
        assert np.array_equal(c["position"][()], d["position"][()])
        names = []
        c.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        for n in names:
            assert c[n].attrs["unit"] and c[n].attrs["description"], n
        assert {"force_N", "deflection_m", "strain/wheel/SG20", "hub_reaction/pinion"} <= set(names)
    t = read_tables(tables, model).mesh("m12")
    c = t.require_coast()
    assert (c.side, c.name, c.pair_shift) == ("coast", "m12", {"pinion": 1, "wheel": 0})
    assert c.base_radius_m == pytest.approx((0.07 * math.cos(math.radians(20.0)),) * 2, rel=1e-12)
    # the coast load grid carries the operating torque over the coast base radius
    assert c.load_N[-1] == pytest.approx(3 * 300.0 / c.base_radius_m[0], rel=1e-12)
    assert c.deflection_m[1] <= c.backlash_normal_m and np.all(c.force_N[:, :2] == 0)


def test_two_sided_round_trip(model_run, tmp_path):
    model, tables = model_run
    t = read_tables(tables, model)
    write_tables(tmp_path / "copy.h5", t)
    a, b = t.mesh().coast, read_tables(tmp_path / "copy.h5", model).mesh().coast
    for k in ("position", "deflection_m", "force_N", "no_load_deflection_m", "load_N", "static_deflection_m",
              "tooth_load_N", "contact_roll_deg", "peak_pressure_Pa", "half_width_m"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    for g in a.gauge_names:
        np.testing.assert_array_equal(a.strain[g], b.strain[g])
    for k in ("side", "flanks", "backlash_normal_m", "backlash_circular_m", "position_offset", "pair_shift", "solver"):
        assert getattr(a, k) == getattr(b, k), k
    c = pickle.loads(pickle.dumps(t.mesh()))
    assert c.coast.force(0.3, 450e-6) == pytest.approx(a.force(0.3, 450e-6))


def test_format_version_1_reads_as_drive_only(model_run, tmp_path, capsys):
    from hacgear_core.cli import main

    model, tables = model_run
    old = tmp_path / "tables.h5"
    shutil.copy(tables, old)
    with h5py.File(old, "r+") as f:   # what a version-1 writer left: no coast group, no side attributes
        del f["meshes/m12/coast"]
        for k in ("side", "flanks"):
            del f["meshes/m12"].attrs[k]
        f.attrs["format_version"] = 1
        del f.attrs["attributes_sha256"]  # version-1 writers stored no attribute digest
    t = read_tables(old, model)
    m = t.mesh("m12")
    assert t.format_version == 1 and m.coast is None and m.side == "drive"
    np.testing.assert_array_equal(m.force_N, read_tables(tables, model).mesh().force_N)
    with pytest.raises(TableError, match=r"no coast side.*hacgear statics"):
        m.require_coast()
    assert main(["statics", str(model), "--check", "--out", str(old)]) == 0
    assert "no coast side" in capsys.readouterr().err
    with h5py.File(old, "r+") as f:
        f.attrs["format_version"] = 4
    with pytest.raises(TableError, match="format_version 4"):
        read_tables(old, model)


def test_coast_table_validation(model_run):
    import dataclasses

    model, tables = model_run
    m = read_tables(tables, model).mesh()
    c = m.coast
    with pytest.raises(TableError, match="backlash_normal_m"):
        dataclasses.replace(c, backlash_normal_m=float("nan"))
    with pytest.raises(TableError, match="pair_shift"):
        dataclasses.replace(c, pair_shift={"pinion": 1})
    with pytest.raises(TableError, match="side"):
        dataclasses.replace(c, side="back")
    with pytest.raises(TableError, match="coast must be a MeshTable"):
        dataclasses.replace(m, coast=m)
    other = read_tables(tables, model).mesh().coast
    with pytest.raises(TableError, match="positions"):
        dataclasses.replace(m, coast=dataclasses.replace(other, position=other.position, teeth=(28, 29)))


@pytest.fixture(scope="module")
def helical_linearisation():
    """The committed helical_28_33 table linearised at its nominal mesh force (200 N*m: W = T / lever arm, the
    force normal to the flank, 3244.1 N) and zero twist, and central finite differences of the statics solver
    (elastic face coupling, as the table) at the same states, at every table position (the mesh-cycle mean is
    the linearisation the modes use; near contact changes a position's table slope is the chord over its
    deflection cell, up to tens of per cent off the local derivative, so a subsample is a noisy quadrature:
    every 8th position gave -1.7 % from position 0 and +3.0 % from position 4 for dW/dgamma): columns dW/dx,
    dW/dgamma, dM/dx, dM/dgamma."""
    model = load_model("helical_28_33")
    table = load_system_tables(model.path).meshes["m12"]
    force = model.operating.torque_Nm / float(table.twist.lever_arm_m[0])
    gs = generalized_stiffness(table, force)
    solver = make_helical_solver(model, "m12")
    idx = np.arange(gs.position.size)
    dx, dg = 1e-8, 1e-5

    def wm(p, x, g):
        st = solver.state_deflection(p, x, twist_rad=g)
        assert st.success
        gf = solver.generalized_forces(st)
        return np.array([gf["mesh_force_N"], gf["twist_moment_Nm"]])

    fd = []
    for k in idx:
        p, x = gs.position[k], gs.deflection_m[k]
        a, b, c, d = wm(p, x + dx, 0.0), wm(p, x - dx, 0.0), wm(p, x, dg), wm(p, x, -dg)
        fd.append([(a[0] - b[0]) / (2 * dx), (c[0] - d[0]) / (2 * dg), (a[1] - b[1]) / (2 * dx),
                   (c[1] - d[1]) / (2 * dg)])
    tab = np.c_[gs.k_xx_N_per_m, gs.k_xg_N_per_rad, gs.k_gx_Nm_per_m, gs.k_gg_Nm_per_rad][idx]
    return tab.mean(axis=0), np.mean(fd, axis=0)


@pytest.mark.slow
def test_helical_mesh_and_coupling_stiffness_match_the_solver(helical_linearisation):
    """Issue #16 (statics side): the generalized force law of the committed helical table, linearised about the
    static state, gives the mesh stiffness dW/dx and the couplings dW/dgamma, dM/dx within 1 % of finite
    differences of the statics solver (mesh-cycle means), and the couplings are reciprocal (a potential)."""
    tab, fd = helical_linearisation
    np.testing.assert_allclose(tab[:3], fd[:3], rtol=0.01)
    assert fd[1] == pytest.approx(fd[2], rel=0.01)


@pytest.mark.slow
def test_helical_twist_stiffness_matches_the_solver(helical_linearisation):
    """Issue #16: the twist stiffness dM/dgamma of the committed table (9 twists, 0.125 mrad apart) within 1 % of
    the solver's (measured -0.06 %, mesh-cycle means over all 64 positions)."""
    tab, fd = helical_linearisation
    assert tab[3] == pytest.approx(fd[3], rel=0.01)


def test_generalized_stiffness_needs_a_twist_axis():
    """A spur table has no twist axis: linearising its generalized force law is refused by name."""
    model = load_model("spur_28t_asym")
    table = load_system_tables(model.path).meshes["m12"]
    with pytest.raises(TableError, match="twist axis"):
        generalized_stiffness(table, 4000.0)


# ----------------------------------------------------------------------------------------------
# every shipped table passes its own check (README: `hacgear statics SYSTEM --check`)
# ----------------------------------------------------------------------------------------------
#: shipped models whose tables are not committed (none: a model without them says why in its readme)
WITHOUT_TABLES: set[str] = set()
SHIPPED = sorted(p.parent.name for p in (REPO / "models").glob("*/model.toml") if p.parent.name not in WITHOUT_TABLES)


def test_the_models_without_tables_are_the_listed_ones():
    """Only the listed models lack their tables.h5 (a new model without tables, or tables added for a listed one,
    changes this list)."""
    missing = {p.parent.name for p in (REPO / "models").glob("*/model.toml") if not (p.parent / "tables.h5").exists()}
    assert missing == WITHOUT_TABLES


@pytest.mark.parametrize("system", SHIPPED)
def test_every_shipped_table_passes_its_check(system, capsys):
    """Every folder of models/ has its committed tables.h5 and ``hacgear statics SYSTEM --check`` passes on it:
    checksums, provenance and physical sanity, the tooth loads adding up to the mesh force on both sides of every
    mesh included (about 1.5 s per table)."""
    from hacgear_core.cli import main

    assert (REPO / "models" / system / "tables.h5").exists(), f"models/{system} has no tables.h5"
    assert main(["statics", system, "--check"]) == 0
    out = capsys.readouterr().out
    assert "OK: checksums, provenance and physical sanity" in out and "FAILED" not in out


@pytest.mark.parametrize("system", ["planetary_65_55_175", "planetary_65_55_175_unmodified"])
def test_planetary_coast_tooth_loads_add_up_to_the_mesh_force(system):
    """The coast side of the internal (ring-planet) mesh has more than three pairs loaded near the end of a mesh cycle
    (4 pairs at drive position 63/64): its tabulated pairs (coast offsets -1..3, centred on the coast flanks' own
    positions c0 - tau) hold every one, so the tooth loads add up to the mesh force (sum over the pairs of the
    normal loads vs the FDF, which is along the line of action) as closely as on the drive side and on the external
    mesh: within 0.6 % of the largest load, per position and deflection (a window -2..2 lost the pair at coast
    offset 3: 11.1 % / 19.1 %)."""
    tabs = load_system_tables(system)
    for mesh in ("sun_planet", "ring_planet"):
        drive = tabs.mesh(mesh)
        for t in (drive, drive.coast):
            err = np.abs(t.tooth_load_N.sum(axis=-1) - t.force_N).max() / t.load_N.max()
            assert err < 6e-3, (mesh, t.side, err)
        assert drive.coast.tooth_offsets.tolist() == [-1, 0, 1, 2, 3]
    ring = tabs.mesh("ring_planet").coast
    # the fourth pair: at coast offset 3 at the end of the cycle, > 5 % of the mesh force at the largest deflection
    assert ring.tooth_load_N[-1, -1, -1] > 0.05 * ring.force_N[-1, -1]


def test_committed_helical_table_is_two_sided(capsys):
    """`hacgear statics helical_28_33 --check` passes with both sides (issue 36): the coast region carries the twist
    axis of the drive side, its own mesh frame (the coast flanks' base helix angle and lever arms: 20 deg transverse
    flanks, so the base radius is r cos(20 deg)) and a deflection grid from below the coast contact
    (backlash_normal_m cos(beta_bc)) upwards; no one-sided warning."""
    import json

    from hacgear_core.cli import main
    from hacgear_core.geometry import gear_geometry

    assert main(["statics", "helical_28_33", "--check", "--json"]) == 0
    cap = capsys.readouterr()
    rep = json.loads(cap.out)
    assert "warnings" not in rep and rep["problems"] == []
    d, c = rep["meshes"]["m12"], rep["meshes"]["m12/coast"]
    assert c["side"] == "coast" and c["flanks"] == ["coast", "coast"]
    assert c["twist_rad"] == d["twist_rad"]
    m = load_model("helical_28_33")
    rb = gear_geometry(m.gears[0]).base_radius_m["coast"]
    assert c["lever_arm_m"][0] == pytest.approx(rb * math.cos(c["base_helix_angle_rad"]), rel=1e-9)
    contact = c["backlash_normal_m"] * math.cos(c["base_helix_angle_rad"])
    assert c["deflection_grid_min_m"] < min(contact, c["no_load_deflection_min_m"]) < c["deflection_grid_max_m"]
    # tan(beta_b) = tan(beta) cos(alpha_t): the 20 deg coast flanks have the larger base helix angle
    assert math.tan(abs(c["base_helix_angle_rad"])) == pytest.approx(
        math.tan(abs(d["base_helix_angle_rad"])) * math.cos(math.radians(20)) / math.cos(math.radians(25)), rel=1e-6)


def test_rename_gears_carries_names_only(tmp_path):
    """rename_gears: a gear rename of the model file carried over to its table keeps every dataset bit for bit,
    renames the per-gear groups and gauge names, records the rename and makes the table belong to the renamed model;
    a model that differs in anything but the names is refused, naming the value, and the file is left as it was."""
    from hacgear_core.tables.rename import RENAMED_ATTR, rename_gears

    src = REPO / "models" / "spur_50t_icr18"
    text = (src / "model.toml").read_text()
    renamed = text.replace('"pinion"', '"gear_a1"').replace('"wheel"', '"gear_b1"')
    assert renamed != text
    tab = tmp_path / "tables.h5"
    shutil.copy(src / "tables.h5", tab)
    bad = tmp_path / "bad.toml"
    bad.write_text(renamed.replace("tip_diameter_mm = 156.06", "tip_diameter_mm = 156.07"))
    before = tab.read_bytes()
    with pytest.raises(TableError, match=r"gears\.gear_a1\.tip_diameter_m: 0\.15606 in the table, 0\.15607 now"):
        rename_gears(tab, {"pinion": "gear_a1", "wheel": "gear_b1"}, bad)
    with pytest.raises(TableError, match=r"renames name gears the table does not have: \['input'\]"):
        rename_gears(tab, {"input": "gear_a1"}, bad)
    assert tab.read_bytes() == before
    good = tmp_path / "model.toml"
    good.write_text(renamed)
    with pytest.raises(TableError, match="does not belong to"):
        read_tables(tab, model_path=good)
    rename_gears(tab, {"pinion": "gear_a1", "wheel": "gear_b1"}, good)
    new, old = read_tables(tab, model_path=good), read_tables(src / "tables.h5", model_path=src / "model.toml")
    assert new.meshes["m12"].gear_names == ("gear_a1", "gear_b1")
    assert np.array_equal(new.meshes["m12"].force_N, old.meshes["m12"].force_N)
    with h5py.File(tab) as f, h5py.File(src / "tables.h5") as g:
        assert sorted(f["meshes/m12/strain"]) == ["gear_a1", "gear_b1"]
        assert list(f["meshes/m12/coast"].attrs["gauge_names"]) == [b"gear_a1/R70p7", b"gear_b1/R70p7"] or \
            list(f["meshes/m12/coast"].attrs["gauge_names"]) == ["gear_a1/R70p7", "gear_b1/R70p7"]
        assert np.array_equal(f["meshes/m12/strain/gear_b1/R70p7"][()], g["meshes/m12/strain/wheel/R70p7"][()],
                              equal_nan=True)
        assert '"renames": {"pinion": "gear_a1", "wheel": "gear_b1"}' in str(f.attrs[RENAMED_ATTR])


def test_flank_and_edge_pressures_are_tabulated_apart(tmp_path):
    """Every shipped table holds the contact pressure split into flank (Hertzian) and tip-edge contacts, the peak
    the larger of the two; the unmodified 50-tooth pair has tip-edge contact (premature / late, off the line of
    action) and `statics --check` notes it; a table without the split (older) reads as None, is noted as such,
    and an inconsistent split is a problem."""
    from dataclasses import replace as dc_replace
    from hacgear_core.tables import read_tables, write_tables
    from hacgear_core.tables.check import pressure_notes, sanity_problems

    for system in ("spur_50t_icr137", "helical_28_33"):
        tabs = read_tables(REPO / "models" / system / "tables.h5")
        for t in tabs.meshes.values():
            for side in (t, t.coast):
                np.testing.assert_array_equal(np.maximum(side.flank_pressure_Pa, side.edge_pressure_Pa),
                                              side.peak_pressure_Pa)
    t = read_tables(REPO / "models" / "spur_50t_icr137" / "tables.h5").mesh("m12")
    assert t.edge_pressure_Pa.max() > 5e9 and t.flank_pressure_Pa.max() < t.edge_pressure_Pa.max()
    assert any(n.startswith("tip-edge contact at ") for n in pressure_notes(t))
    bad = dc_replace(t, flank_pressure_Pa=t.flank_pressure_Pa * 0.5, coast=None)
    assert any("their larger differs from peak_pressure_Pa" in p for p in sanity_problems(bad))
    tabs = read_tables(REPO / "models" / "spur_50t_icr137" / "tables.h5")
    old = dc_replace(tabs, meshes={m: dc_replace(v, flank_pressure_Pa=None, edge_pressure_Pa=None,
                                                 coast=dc_replace(v.coast, flank_pressure_Pa=None,
                                                                  edge_pressure_Pa=None))
                                   for m, v in tabs.meshes.items()})
    write_tables(tmp_path / "old.h5", old)
    back = read_tables(tmp_path / "old.h5").mesh("m12")
    assert back.flank_pressure_Pa is None and back.edge_pressure_Pa is None
    assert np.isnan(back.pressure(0.3, 2e-5, "edge")) and back.pressure(0.3, 2e-5) >= 0
    assert pressure_notes(back) and "not told apart" in pressure_notes(back)[0]


def test_twist_tables_without_gauges_read_back(tmp_path):
    """A helical mesh's twist tables of a model without strain gauges (the NREL 5 MW stage 3) have no strain
    datasets: they read back (KeyError 'strain_twist' before) with empty strains, the forces as written."""
    import dataclasses

    m = load_model("helical_28_33")
    t = read_tables(m.tables_path, m.path)

    def bare(side):
        return dataclasses.replace(side, strain={},
                                   twist=dataclasses.replace(side.twist, strain={}))

    meshes = {k: dataclasses.replace(bare(v), coast=None if v.coast is None else bare(v.coast))
              for k, v in t.meshes.items()}
    write_tables(tmp_path / "bare.h5", dataclasses.replace(t, meshes=meshes))
    back = read_tables(tmp_path / "bare.h5")
    for k, v in back.meshes.items():
        assert v.twist is not None and v.twist.strain == {} and v.strain == {}
        np.testing.assert_array_equal(v.twist.generalized_fdf, t.meshes[k].twist.generalized_fdf)


def test_a_constant_twist_axis_reproduces_the_spur_table_at_every_twist():
    """with_constant_twist: the lifted table's generalized FDF is the spur table's force at any twist (at the
    grid twist 0 to the last bit of the bilinear rule's value, elsewhere to rounding), with zero twist moment;
    per-pair strains repeat along the twist, the coast side is lifted too, a helical table is returned as it is."""
    from hacgear_core.model import resolve_model_path
    from hacgear_core.tables import load_system_tables, with_constant_twist

    spur = load_system_tables(resolve_model_path("reducer_19_71_23_83")).mesh("m12")
    lifted = with_constant_twist(spur)
    assert lifted.twist is not None and lifted.coast is not None and lifted.coast.twist is not None
    rng = np.random.default_rng(3)
    tau = rng.random(400) * 3 - 1
    x = spur.deflection_m[0] + rng.random(400) * (spur.deflection_m[-1] - spur.deflection_m[0])
    ref = spur.force(tau, x)
    for g in (0.0, 0.3, -0.77):
        wm = lifted.twist_quantity(lifted.twist.generalized_fdf, tau, x, np.full(400, g))
        np.testing.assert_allclose(wm[:, 0], ref, rtol=1e-13, atol=1e-9 * np.max(ref))
        assert np.all(wm[:, 1] == 0.0)
    for gauge, a in spur.strain.items():
        np.testing.assert_array_equal(lifted.twist.strain[gauge][:, :, 1, :], a)
    helical = load_system_tables(resolve_model_path("helical_28_33")).mesh("m12")
    assert with_constant_twist(helical) is helical

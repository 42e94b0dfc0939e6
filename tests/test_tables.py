"""tables.h5: schema and provenance, model-hash refusal, interpolation policy (nodes, monotonicity,
periodicity, extrapolation counting), numba kernel, round trip."""
from __future__ import annotations

import math
import pickle
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from hacgear_core.errors import TableError
from hacgear_core.statics import AnalyticFactory, compute_statics, load_grid, run_statics
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
    "peak_pressure_Pa": "Pa", "done_loads": "1", "done_deflections": "1",
}


def test_every_dataset_has_unit_description_and_shape(h5):
    nw = 5
    shapes = {
        "position": (NP,), "load_N": (NL,), "deflection_m": (ND,), "no_load_deflection_m": (NP,),
        "static_deflection_m": (NP, NL), "force_N": (NP, ND), "tooth_offsets": (nw,), "tooth_load_N": (NP, ND, nw),
        "contact_roll_deg": (NP, ND, nw), "half_width_m": (NP, ND, nw), "peak_pressure_Pa": (NP, ND),
        "done_loads": (NP,), "done_deflections": (NP,),
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
def test_hash_mismatch_refused_and_override(model_run, tmp_path):
    model, tables = model_run
    t = read_tables(tables, model)  # matches
    assert t.model_sha256 == __import__("hashlib").sha256(model.read_bytes()).hexdigest()
    assert load_system_tables(model).mesh().n_positions == 8
    changed = tmp_path / "model.toml"
    changed.write_bytes(model.read_bytes() + b"\n# edited\n")
    with pytest.raises(TableError) as exc:
        read_tables(tables, changed)
    msg = str(exc.value)
    assert str(tables) in msg and str(changed) in msg and f"hacgear statics {changed}" in msg
    assert "--ignore-model-hash" in msg
    t2 = read_tables(tables, changed, allow_hash_mismatch=True)
    np.testing.assert_array_equal(t2.mesh().force_N, t.mesh().force_N)


def test_cli_check_and_ignore_model_hash(model_run, tmp_path, capsys):
    from hacgear_core.cli import main

    model, tables = model_run
    assert main(["statics", str(model), "--check", "--json"]) == 0
    assert '"positions": 8' in capsys.readouterr().out
    changed = tmp_path / "model.toml"
    changed.write_bytes(model.read_bytes() + b"\n# edited\n")
    assert main(["statics", str(changed), "--check", "--out", str(tables)]) == 2
    assert "does not belong" in capsys.readouterr().err
    assert main(["statics", str(changed), "--check", "--out", str(tables), "--ignore-model-hash"]) == 0


def test_incomplete_and_foreign_files_refused(h5, tmp_path):
    bad = tmp_path / "inc.h5"
    shutil.copy(h5, bad)
    with h5py.File(bad, "r+") as f:
        f["meshes/m12/done_deflections"][5] = 0
    with pytest.raises(TableError, match="incomplete.*--resume"):
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

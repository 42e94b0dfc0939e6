"""Studies built on the static contact solver: stiffness and STE over a mesh cycle, model variants
(without relief/crowning), root-strain scans along the fillet."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace as _replace
from typing import Any

import numpy as np

from hacgear_core.errors import GeometryError, ModelError, SolverError
from hacgear_core.geometry import gear_geometry, mesh_geometry
from hacgear_core.model import Flank, Gauge, Model
from hacgear_core.kinds import load_model
from hacgear_core.statics.grid import nominal_mesh_forces
from hacgear_core.statics.contact import ContactOptions, MeshContactSolver, default_contact_options, make_mesh_solver
from hacgear_core.statics.helical import HelicalMeshContactSolver, make_solver

__all__ = [
    "StiffnessCurve",
    "mesh_stiffness_curve",
    "mesh_stiffness_report",
    "helical_mesh_report",
    "model_variant",
    "RootStrainScan",
    "root_strain_scan",
]

@dataclass(frozen=True)
class StiffnessCurve:
    """Static transmission error and mesh stiffness over one mesh cycle at one mesh force.

    ``mesh_cycle`` (n,), ``ste_m`` (n,) static mesh deflection [m], ``no_load_deflection_m`` (n,),
    ``local_slope_stiffness_N_per_m`` (n,) ``dW/dx`` at the load, ``mean_mesh_stiffness_N_per_m``
    (mean of the local slope), ``secant_mesh_stiffness_N_per_m`` (``W / mean(x)``),
    ``average_slope_stiffness_N_per_m`` (n,) ``W / (x - x0)`` with ``x0`` the no-load deflection
    (the "average slope" of dissertation Section 3.5), ``mesh_force_N``.
    """

    mesh_cycle: np.ndarray
    ste_m: np.ndarray
    no_load_deflection_m: np.ndarray
    local_slope_stiffness_N_per_m: np.ndarray
    mean_mesh_stiffness_N_per_m: float
    secant_mesh_stiffness_N_per_m: float
    mesh_force_N: float
    tooth_load_N: np.ndarray
    seconds: float
    average_slope_stiffness_N_per_m: np.ndarray = field(default_factory=lambda: np.zeros(0))


def mesh_stiffness_curve(solver: MeshContactSolver, mesh_force_N: float, positions: int = 64,
                         rel_step: float = 0.02, twist_rad: float = 0.0, on_position=None) -> StiffnessCurve:
    """Static transmission error and mesh stiffness over one mesh cycle (at mesh twist ``twist_rad`` [rad] for a
    face-resolving solver).  ``on_position(done, total)``, if given, is called after each position's solves.

    The local-slope stiffness at each position is the central difference ``dW/dx`` from two
    load-controlled solves at ``W (1 ± rel_step)``.
    """
    tw = {} if not isinstance(solver, HelicalMeshContactSolver) else {"twist_rad": float(twist_rad)}
    if twist_rad and not tw:
        raise ModelError("a mesh twist needs the face-resolving (helical) solver")
    if not (isinstance(positions, (int, np.integer)) and 2 <= positions <= 4096):
        raise ModelError(f"positions must be an integer in [2, 4096], got {positions!r}")
    W = float(mesh_force_N)
    if not (math.isfinite(W) and W > 0):
        raise ModelError(f"mesh force must be finite and > 0 N, got {mesh_force_N!r}")
    t0 = time.perf_counter()
    pos = np.arange(positions) / positions
    x = np.zeros(positions)
    x0 = np.zeros(positions)
    k = np.zeros(positions)
    loads = np.zeros((positions, len(solver.tooth_offsets)))
    for i, p in enumerate(pos):
        st = solver.state_load(p, W, **tw)
        if not st.success:
            raise SolverError(f"contact solve failed at position {p:.4f}: {st.message}")
        lo = solver.state_load(p, W * (1 - rel_step), warm=st.force_N, **tw)
        hi = solver.state_load(p, W * (1 + rel_step), warm=st.force_N, **tw)
        x[i] = st.mesh_deflection_m
        x0[i] = solver.no_load_deflection(p, **tw)
        k[i] = 2 * rel_step * W / (hi.mesh_deflection_m - lo.mesh_deflection_m)
        pr = solver.pair_results(st)
        for j, pp in enumerate(st.setup.pairs):
            m = np.flatnonzero(solver.tooth_offsets == pp)
            if m.size:
                loads[i, m] = pr["load_N"][j]
        if on_position is not None:
            on_position(i + 1, positions)
    return StiffnessCurve(mesh_cycle=pos, ste_m=x, no_load_deflection_m=x0, local_slope_stiffness_N_per_m=k,
                          mean_mesh_stiffness_N_per_m=float(k.mean()),
                          secant_mesh_stiffness_N_per_m=float(W / x.mean()), mesh_force_N=W, tooth_load_N=loads,
                          seconds=time.perf_counter() - t0, average_slope_stiffness_N_per_m=W / (x - x0))




def model_variant(model: Any, *, tip_relief: bool = True, lead_crowning: bool = True,
                  hob_tip_radius_m: float | None = None) -> Any:
    """Copy of ``model`` with every gear's tip relief and/or lead crowning removed, or its hob tip
    radius [m] replaced (studies of dissertation Figs. 2.5 and 2.7).  The copy keeps the model's
    ``sha256``/``path`` (it is not a file), so never write tables from it."""
    gears = []
    for g in model.gears:
        kw: dict[str, Any] = {}
        if not tip_relief:
            kw["flanks"] = {k: Flank(f.pressure_angle_rad) for k, f in g.flanks.items()}
        if not lead_crowning:
            kw["lead_crowning_m"] = 0.0
        if hob_tip_radius_m is not None:
            kw["hob_tip_radius_m"] = float(hob_tip_radius_m)
        gears.append(_replace(g, **kw))
    return _replace(model, gears=tuple(gears))


@dataclass(frozen=True)
class RootStrainScan:
    """Surface strain along the root of one tooth over mesh positions (dissertation Fig. 2.7).

    ``position`` (Np,) mesh cycles, ``radius_m`` (Ng,) gauge radii, ``s_m`` (Ng,) their profile
    coordinate (arc length from the tip of the loaded flank), ``strain`` (Np, Ng) on the tooth of
    the reference pair of gear ``gear``, ``tooth_load_N`` (Np,) its load, ``max_strain`` and where
    (``max_position``, ``max_radius_m``, ``max_s_m``).  ``sampling`` and ``gauge_length_m`` record
    how the points were placed and whether each strain is a point value (0) or the mean over a
    gauge grid of that length along the profile.
    """

    gear: str
    position: np.ndarray
    radius_m: np.ndarray
    s_m: np.ndarray
    strain: np.ndarray
    tooth_load_N: np.ndarray
    max_strain: float
    max_position: float
    max_radius_m: float
    max_s_m: float = float("nan")
    sampling: str = "arc"
    gauge_length_m: float = 0.0


def root_strain_scan(model: Any, mesh_name: str, mesh_force_N: float, *, gear: int = 1, n_gauges: int = 24,
                     positions: int = 128, span: tuple[float, float] = (-1.0, 1.0),
                     options: ContactOptions | None = None, fe_options: Any = None, sampling: str = "arc",
                     gauge_length_m: float = 0.0, gauge_points: int = 9) -> RootStrainScan:
    """Strain at ``n_gauges`` points of the loaded flank's root (from just above the root circle up
    to the start of the active profile) of gear ``gear`` (0 = gear_a, 1 = gear_b) on the tooth of the
    reference pair, over ``positions`` mesh positions in ``span`` [mesh cycles], load control.

    The strain is the surface strain along the profile tangent in the transverse plane (a gauge
    bonded along the profile, dissertation Fig. 2.2(b): gauge ends S1, S2 "along the tooth profile").

    Parameters
    ----------
    sampling : {"radius", "arc"}
        Where the ``n_gauges`` points lie between ``r_f + 0.02 (r_SAP - r_f)`` and the SAP radius:
        equally spaced in arc length along the profile (default) or equally spaced in radius.  On a
        fillet the radius changes slowly near the root circle, so ``"radius"`` puts few points
        where small tool tip radii have their narrow strain peak (28-tooth gear, 0.4 mm tool, 24
        points: the maximum is 2.5 % low); ``"arc"`` resolves it with the same count.
    gauge_length_m : float
        0 (default): point strain.  > 0: each value is the mean surface strain over an arc of this
        length [m] along the profile centred on the point (a gauge grid), evaluated at
        ``gauge_points`` equally spaced points (midpoint rule); the arc is clipped to the flank
        (it ends at the fillet bottom).  Allowed: 0 <= gauge_length_m <= 5e-3 m.
    gauge_points : int
        Points per gauge grid when ``gauge_length_m`` > 0 (2..41).
    """
    if not isinstance(model, Model):
        model = load_model(model)
    meshes = {m.name: m for m in model.meshes}
    if mesh_name not in meshes:
        raise ModelError(f"unknown mesh {mesh_name!r}; the model has: {', '.join(meshes) or '(none)'}")
    if gear not in (0, 1):
        raise ModelError(f"gear must be 0 (gear_a) or 1 (gear_b), got {gear!r}")
    if not (isinstance(n_gauges, (int, np.integer)) and 2 <= n_gauges <= 200):
        raise ModelError(f"n_gauges must be an integer in [2, 200], got {n_gauges!r}")
    if sampling not in ("radius", "arc"):
        raise ModelError(f"sampling must be 'radius' or 'arc', got {sampling!r}")
    if not (isinstance(gauge_length_m, (int, float, np.floating)) and np.isfinite(gauge_length_m)
            and 0.0 <= gauge_length_m <= 5e-3):
        raise ModelError(f"gauge_length_m must be in [0, 5e-3] m, got {gauge_length_m!r}")
    if not (isinstance(gauge_points, (int, np.integer)) and 2 <= gauge_points <= 41):
        raise ModelError(f"gauge_points must be an integer in [2, 41], got {gauge_points!r}")
    mesh = meshes[mesh_name]
    gname = (mesh.gear_a, mesh.gear_b)[gear]
    side = (mesh.flank_a, mesh.flank_b)[gear]
    g = {x.name: x for x in model.gears}[gname]
    gg = gear_geometry(g)
    mg = mesh_geometry(model, mesh_name)
    rb = gg.base_radius_m[side]
    r_sap = rb * math.sqrt(1.0 + math.radians(mg.roll_angle_deg[gname]["SAP"]) ** 2)
    r_lo = gg.root_radius_m + 0.02 * (r_sap - gg.root_radius_m)
    legacy = sampling == "radius" and gauge_length_m == 0
    # arc length <-> radius along the flank (tip to fillet bottom; the radius is monotone there)
    prof = gg.flank(side, 4000)
    ps, pr, preg = np.asarray(prof.s, float), np.asarray(prof.radius, float), np.asarray(prof.region)
    keep = preg != 0                                    # drop the root land (constant radius)
    o = np.argsort(ps[keep])
    fs, fr = ps[keep][o], pr[keep][o]
    if not legacy and np.any(np.diff(fr) * (1.0 if gg.internal else -1.0) < -1e-12):
        raise GeometryError(f"root_strain_scan: the {side} flank radius is not monotone along the profile")
    sgn = 1.0 if gg.internal else -1.0                  # external: radius falls from tip to root
    s_of_r = lambda r: np.interp(sgn * np.asarray(r), sgn * fr, fs)          # noqa: E731
    r_of_s = lambda s: np.interp(np.asarray(s), fs, fr)                      # noqa: E731
    if sampling == "radius":
        radii = np.linspace(r_lo, r_sap, n_gauges)
        s_c = s_of_r(radii)
    else:
        s_c = np.linspace(float(s_of_r(r_lo)), float(s_of_r(r_sap)), n_gauges)
        radii = r_of_s(s_c)
    if gauge_length_m > 0:
        u = ((np.arange(gauge_points) + 0.5) / gauge_points - 0.5) * gauge_length_m
        s_sub = np.clip(s_c[:, None] + u[None, :], fs[0], fs[-1] - 1e-9)    # (Ng, n) clipped to the flank
        r_sub = r_of_s(s_sub)
    else:
        r_sub = radii[:, None]
    nsub = r_sub.shape[1]
    gauges = [(gname, Gauge(f"R{i:03d}_{j:02d}", side, float(r_sub[i, j])))
              for i in range(n_gauges) for j in range(nsub)]
    solver = make_mesh_solver(model, mesh_name, options=options, fe_options=fe_options, gauges=gauges)
    fc = solver.compliance[gear]
    s_all = np.array([gi["s_m"] for gi in fc.info["gauges"]]).reshape(n_gauges, nsub)
    s_g = s_all.mean(axis=1) if nsub > 1 else s_all[:, 0]
    pos = np.linspace(span[0], span[1], positions, endpoint=False)
    eps = np.zeros((positions, n_gauges))
    load = np.zeros(positions)
    names = [[f"{gname}/R{i:03d}_{j:02d}" for j in range(nsub)] for i in range(n_gauges)]
    for i, p in enumerate(pos):
        st = solver.state_load(p, mesh_force_N)
        if not st.success:
            raise SolverError(f"contact solve failed at position {p:.4f}: {st.message}")
        e = solver.strains(st, offsets=[0])
        eps[i] = [np.mean([e[nm][0] for nm in row]) for row in names]
        pr_ = solver.pair_results(st)
        hit = np.flatnonzero(st.setup.pairs == 0)
        load[i] = pr_["load_N"][hit[0]] if hit.size else 0.0
    k = np.unravel_index(int(np.argmax(eps)), eps.shape)
    return RootStrainScan(gear=gname, position=pos, radius_m=radii, s_m=s_g, strain=eps, tooth_load_N=load,
                          max_strain=float(eps[k]), max_position=float(pos[k[0]]), max_radius_m=float(radii[k[1]]),
                          max_s_m=float(s_g[k[1]]), sampling=sampling, gauge_length_m=float(gauge_length_m))


def helical_mesh_report(solver: HelicalMeshContactSolver, mesh_force_N: float, positions: int = 64,
                        twist_rad: float = 0.0, twist_step_rad: float = 1e-5) -> dict:
    """What a face-resolving solve adds over a mesh cycle at the mesh force [N] and twist [rad] (load control):
    twist moment, twist stiffness ``dM/dgamma`` at the static deflection (central difference, deflection control,
    ``± twist_step_rad``), contact pattern (load per face slice), load centroid across the face, peak pressure,
    the generalized forces f_d, gauge strains, and the definitions (r_mesh, r_twist).  SI, unit in the keys."""
    pos = np.arange(positions) / positions
    ns = solver.options.face_slices
    M = np.zeros(positions)
    kg = np.zeros(positions)
    pat = np.zeros((positions, ns))
    pres = np.zeros(positions)
    fd = np.zeros((positions, 12))
    resid = np.zeros(positions)
    strains = {g: np.zeros(positions) for g in solver.gauge_names}
    zs = solver.z_centre_m + solver.slice_z_m
    for i, p in enumerate(pos):
        st = solver.state_load(p, mesh_force_N, twist_rad=twist_rad)
        if not st.success:
            raise SolverError(f"contact solve failed at position {p:.4f}: {st.message}")
        gf = solver.generalized_forces(st)
        M[i], fd[i], resid[i] = gf["twist_moment_Nm"], gf["f_d"], gf["identity_residual"]
        pt = solver.pattern(st)
        pat[i] = pt["load_N"].sum(axis=0)
        pres[i] = float(st.peak_pressure_Pa.max())
        eps = solver.strains(st, offsets=[0])
        for g in strains:
            strains[g][i] = eps[g][0]
        x = st.mesh_deflection_m
        up = solver.state_deflection(p, x, warm=st.force_N, twist_rad=twist_rad + twist_step_rad)
        dn = solver.state_deflection(p, x, warm=st.force_N, twist_rad=twist_rad - twist_step_rad)
        kg[i] = (solver.generalized_forces(up)["twist_moment_Nm"] - solver.generalized_forces(dn)["twist_moment_Nm"]) \
            / (2 * twist_step_rad)
    tot = pat.sum(axis=1)
    centroid = (pat @ zs) / np.where(tot > 0, tot, 1.0)
    fr = solver.frame
    return {
        "twist_rad": float(twist_rad), "twist_moment_Nm": M.tolist(), "mean_twist_moment_Nm": float(M.mean()),
        "twist_stiffness_Nm_per_rad": kg.tolist(), "mean_twist_stiffness_Nm_per_rad": float(kg.mean()),
        "slice_z_m": zs.tolist(), "slice_load_N": pat.tolist(), "mean_slice_load_N": pat.mean(axis=0).tolist(),
        "load_centroid_z_m": centroid.tolist(), "mean_load_centroid_z_m": float(centroid.mean()),
        "face_overlap_m": [float(zs[0] - solver.slice_width_m / 2), float(zs[-1] + solver.slice_width_m / 2)],
        "peak_pressure_Pa": pres.tolist(), "max_peak_pressure_Pa": float(pres.max()),
        "generalized_force": fd.tolist(), "identity_residual_max": float(resid.max()),
        "gauge_strain": {g: v.tolist() for g, v in strains.items()},
        "r_mesh": fr.r_mesh.tolist(), "r_twist": fr.r_twist.tolist(),
        "base_helix_angle_rad": fr.base_helix_angle_rad, "lever_arm_m": list(fr.lever_arm_m),
        "reference_plane_z_m": fr.reference_plane_z_m,
        "mesh_frame": {"e1": fr.e1.tolist(), "e2": fr.e2.tolist(), "e3": fr.e3.tolist(), "P_ref_m": fr.P_ref.tolist(),
                       "n_ref": fr.n_ref.tolist(), "O_a_m": fr.O[0].tolist(), "O_b_m": fr.O[1].tolist()},
    }


def mesh_stiffness_report(model: Any, torque_Nm: float, *, mesh: str | None = None, positions: int = 64,
                          slices: int | None = None, face_coupling: str | None = None, twist_rad: float = 0.0,
                          side: str = "drive", progress=None, on_position=None, done=None, on_mesh=None) -> dict:
    """Static transmission error and mesh stiffness of every mesh (or of ``mesh``) of ``model`` under ``torque_Nm``
    [N m] on ``model.operating.torque_gear``: each mesh is loaded with the force that the torque flow through the
    train gives it (the model's kind: :func:`hacgear_core.statics.grid.nominal_mesh_forces`), reported as the torque on its gear_a.

    ``side="coast"`` (spur meshes): the same torque reversed, loading the opposite flank of each gear (base radii,
    flanks, relief and gauges of that side).  Positions (``mesh_cycle``) are then the coast flank pair's own (0 =
    a coast pair at the pitch point; ``mesh_cycle_drive`` gives the drive-side position of each) and the STE is
    the coast mesh deflection from the coast flanks' kinematic contact (add ``backlash_normal_m`` for the coast
    approach from the drive kinematic position, the coast tables' deflection axis).  ``twist_rad``: mesh twist of
    helical meshes.  ``progress(message)``, if given, is called before each mesh's two long stages (building its
    finite-element model, solving the contact at the positions), ``on_position(done, total)`` after each position
    (:func:`mesh_stiffness_curve`).  ``done`` {mesh name: its entry of ``meshes``}: results of an earlier run of
    the same inputs (:mod:`hacgear_core.statics.stiffness_file`), taken as they are and not solved again;
    ``on_mesh(report)``, if given, is called with the report so far (solved and reused meshes, in model order)
    after each mesh it solves, so the caller can write it before the next mesh starts.

    Returns a dict (SI, unit in the key names): ``model``, ``torque_Nm``, ``torque_gear``, ``side`` and ``meshes``
    {name: mesh force, base radii, flanks, mean (local-slope), secant and average-slope stiffness, STE over the
    cycle, NLMD, tooth loads, seconds; coast side also the backlash; helical meshes also twist moment, stiffness
    and contact pattern}.
    """
    if side not in ("drive", "coast"):
        raise ModelError(f"side = {side!r}; allowed: drive | coast")
    if not (math.isfinite(torque_Nm) and torque_Nm > 0):
        raise ModelError(f"torque [N*m] must be finite and > 0, got {torque_Nm!r}")
    if not 2 <= positions <= 4096:
        raise ModelError(f"positions must be in [2, 4096], got {positions}")
    names = [m.name for m in model.meshes]
    if mesh is not None and mesh not in names:
        raise ModelError(f"mesh {mesh!r} is not a mesh of the model; allowed: {', '.join(names)}")
    done = dict(done or {})
    extra = sorted(set(done) - {n for n in names if mesh is None or n == mesh})
    if extra:
        raise ModelError(f"done: results of mesh(es) {', '.join(extra)} that this run does not solve; allowed: "
                         f"{mesh or ', '.join(names)}")
    helical = any(g.is_helical for g in model.gears)
    if helical and side == "coast":
        raise ModelError("side = 'coast': this report covers the drive side of helical meshes only (their coast side "
                         "is in the tables: hacgear statics --check, hacgear simulate --torque -T); allowed: drive")
    if face_coupling is None:
        face_coupling = "elastic" if helical else "rigid"
    if twist_rad and not (helical or face_coupling == "elastic"):
        raise ModelError("--twist [rad] applies to helical meshes (or face_coupling 'elastic') only")
    geo = {m.name: mesh_geometry(model, m.name, strict=False) for m in model.meshes}
    opts = ContactOptions(face_slices=slices if slices is not None else model.statics.face_slices,
                          face_coupling=face_coupling)
    out = {"model": model.name, "torque_Nm": float(torque_Nm), "torque_gear": model.operating.torque_gear,
           "side": side, "face_slices": opts.face_slices, "face_coupling": opts.face_coupling, "meshes": {}}
    if side == "coast":
        radii = {n: (g.base_radius_coast_m[g.gear_a], g.base_radius_coast_m[g.gear_b]) for n, g in geo.items()}
        coast_forces = nominal_mesh_forces(model, radii, torque_Nm=torque_Nm)
    for m in model.meshes:
        if mesh is not None and m.name != mesh:
            continue
        if m.name in done:
            out["meshes"][m.name] = done[m.name]
            continue
        if progress is not None:
            progress(f"mesh {m.name}: building the finite-element model of its gears")
        mopts = default_contact_options(model, m.name, face_slices=opts.face_slices, face_coupling=opts.face_coupling)
        if side == "coast":
            solver = make_mesh_solver(model, m.name, options=mopts, side="coast")
            force = coast_forces[m.name]
        else:
            solver = make_solver(model, m.name, options=mopts)
            lever = getattr(solver, "lever_arm_m", solver.base_radius_m)
            force = nominal_mesh_forces(model, {m.name: tuple(lever)}, torque_Nm=torque_Nm)[m.name] \
                if len(model.meshes) == 1 else _train_force(model, torque_Nm, m.name, solver, geo)
        if progress is not None:
            progress(f"mesh {m.name}: static contact at {positions} mesh positions")
        c = mesh_stiffness_curve(solver, force, positions=positions, twist_rad=twist_rad, on_position=on_position)
        extra = {}
        if side == "coast":
            g = geo[m.name]
            extra = {"backlash_normal_m": g.backlash_normal_m, "backlash_circular_m": g.backlash_circular_m,
                     "mesh_cycle_drive": np.mod(g.coast_position_offset - c.mesh_cycle, 1.0).tolist()}
        out["meshes"][m.name] = {
            "side": side, "flanks": list(solver.flanks), **extra,
            "gear_a": solver.gear_names[0], "gear_b": solver.gear_names[1],
            "torque_Nm": force * solver.base_radius_m[0], "torque_gear": solver.gear_names[0],
            "mesh_force_N": force, "base_radius_m": list(solver.base_radius_m),
            "mean_mesh_stiffness_N_per_m": c.mean_mesh_stiffness_N_per_m,
            "secant_mesh_stiffness_N_per_m": c.secant_mesh_stiffness_N_per_m,
            "local_slope_stiffness_N_per_m": c.local_slope_stiffness_N_per_m.tolist(),
            "mean_average_slope_stiffness_N_per_m": float(c.average_slope_stiffness_N_per_m.mean()),
            "ste_m": c.ste_m.tolist(),
            "ste_peak_to_peak_m": float(c.ste_m.max() - c.ste_m.min()),
            "no_load_deflection_m": c.no_load_deflection_m.tolist(),
            "mesh_cycle": c.mesh_cycle.tolist(),
            "tooth_offsets": [int(k) for k in solver.tooth_offsets],
            "tooth_load_N": c.tooth_load_N.tolist(),
            "seconds": c.seconds,
        }
        if isinstance(solver, HelicalMeshContactSolver):
            out["meshes"][m.name]["torque_Nm"] = force * lever[0]
            out["meshes"][m.name]["helical"] = helical_mesh_report(solver, force, positions=positions,
                                                                   twist_rad=twist_rad)
        if on_mesh is not None:
            on_mesh(out)
    return out


def _train_force(model: Any, torque_Nm: float, mesh_name: str, solver: Any, geo: dict) -> float:
    """Force of one mesh of a train under ``torque_Nm``: the train's torque flow (the loaded flanks' base radii
    of the meshes ``geo``), divided by the cosine of the base helix angle when the solver's mesh force is normal to
    the flank."""
    radii = {n: (g.base_radius_m[g.gear_a], g.base_radius_m[g.gear_b]) for n, g in geo.items()}
    f = nominal_mesh_forces(model, radii, torque_Nm=torque_Nm)[mesh_name]
    lever = getattr(solver, "lever_arm_m", None)
    return f if lever is None else f * solver.base_radius_m[0] / lever[0]

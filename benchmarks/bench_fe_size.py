"""Any size (#51 item 2): the finite-element model of one gear at module 1, 5 and 45 mm, and of a 56-tooth internal
gear at module 45 mm — DOF count, build wall time and peak RSS, each measured in its own subprocess.

Cases (ISO 21771 form, rack A, x = 0, lengths module-scaled by default, ``[statics] fe_lengths = "auto"``):
``ext28_m1``, ``ext28_m5``, ``ext28_m45``: the 28-tooth pinion of a 28/33 pair (bore 6 m_n); ``int56_m5``,
``int56_m45``: the 56-tooth ring of a 22/17/56 planetary set (rim diameter 1.2 d; rack A's 0.38 m_n root radius
does not fit the ring's shaper: its full radius 0.331 m_n, docs/geometry.md).  ``--absolute`` adds
``ext28_m10_absolute``: the module-10 pinion with the fixed lengths of the transverse form (``fe_lengths = "absolute"``: 0.6 mm at the flanks,
3 mm in the body), what every gear got before.  What is timed: meshing the gear, assembling and factorising it and
the influence coefficients of one loaded flank (:func:`hacgear_core.statics.fe.gear_compliance`, on-disk cache
off); the peak RSS is the subprocess's own ``getrusage(RUSAGE_SELF).ru_maxrss`` (Python and the imports included).
The ratio max/min of the DOF count and of the peak RSS over the modules of each gear (the 28-tooth external gear at
module 1, 5, 45; the 56-tooth internal gear at module 5, 45) is judged against ±20 % (a gear of more teeth has more
elements: the criterion is that the module does not change the cost).

``--statics`` adds the worker-sharing measurement: ``compute_statics`` of the module-45 pair on a 4 x 2 x 4 grid,
both sides, 2 workers, a cold FE cache, with the FE models built once before the workers (now) and without that
step (each worker builds what its solvers need, as before); the peak of the summed RSS of the process tree
(sampled every 20 ms with psutil) and the wall time.

Run: ``python benchmarks/bench_fe_size.py [--absolute] [--statics] [--json out.json]``.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
from pathlib import Path

from hacgear_core.cpu import vector_units

CASES = ("ext28_m1", "ext28_m5", "ext28_m45", "int56_m5", "int56_m45")

_GEAR = """[[gears]]
name = "{name}"
teeth = {z}
{extra}normal_module_mm = {m!r}
normal_pressure_angle_deg = 20.0
basic_rack = "A"
face_width_mm = {b!r}
bore_diameter_mm = {bore!r}
material = "steel"
"""
_HEAD = """[system]
name = "{name}"
kind = "{kind}"
[materials.steel]
density_kg_per_m3 = 7850.0
youngs_modulus_GPa = 206.0
poisson_ratio = 0.3
"""
_TAIL = """[damping]
modal_damping_ratio = 0.02
[operating]
torque_Nm = {torque!r}
torque_gear = "{tgear}"
{statics}"""


def pair_toml(m_mm: float, statics: str = "") -> str:
    """ISO-form spur pair 28/33 of normal module ``m_mm`` [mm]."""
    gears = "".join(_GEAR.format(name=n, z=z, extra="", m=m_mm, b=10 * m_mm, bore=6 * m_mm)
                    for n, z in (("pinion", 28), ("wheel", 33)))
    return (_HEAD.format(name="iso_pair", kind="spur_pair") + gears
            + '[[meshes]]\nname = "m"\ngear_a = "pinion"\ngear_b = "wheel"\n'
            + _TAIL.format(torque=1e3 * m_mm ** 2, tgear="pinion", statics=statics))


def planetary_toml(m_mm: float) -> str:
    """ISO-form planetary set 22/17/56 (ring internal) of normal module ``m_mm`` [mm], x = 0, carrier radius the
    reference centre distance; the sun and the planets thinned by small allowances for backlash."""
    allow = "thickness_allowance_upper_mm = {u!r}\nthickness_allowance_lower_mm = {lo!r}\n".format(
        u=-0.007 * m_mm, lo=-0.014 * m_mm)
    gears = (_GEAR.format(name="sun", z=22, extra="", m=m_mm, b=10 * m_mm, bore=6 * m_mm) + allow
             + _GEAR.format(name="planet", z=17, extra="", m=m_mm, b=10 * m_mm, bore=6 * m_mm) + allow
             + _GEAR.format(name="ring", z=56, extra="internal = true\n", m=m_mm, b=10 * m_mm, bore=1.2 * 56 * m_mm))
    meshes = ('[[meshes]]\nname = "sun_planet"\ngear_a = "sun"\ngear_b = "planet"\n'
              '[[meshes]]\nname = "ring_planet"\ngear_a = "planet"\ngear_b = "ring"\nflank_a = "coast"\n'
              'flank_b = "drive"\n')
    return (_HEAD.format(name="iso_planetary", kind="planetary") + gears + meshes
            + f"[planetary]\nplanet_count = 3\ncarrier_radius_mm = {0.5 * m_mm * 39!r}\nfixed_member = \"ring\"\n"
            + _TAIL.format(torque=1e3 * m_mm ** 2, tgear="sun", statics=""))


def _case_model(case: str, folder: Path):
    from hacgear_core.kinds import load_model

    kind, _, rest = case.partition("_")
    m = float(rest.split("_")[0][1:])
    statics = '[statics]\nfe_lengths = "absolute"\n' if case.endswith("_absolute") else ""
    text = pair_toml(m, statics) if kind == "ext28" else planetary_toml(m)
    (folder / "model.toml").write_text(text)
    model = load_model(folder / "model.toml")
    name = "pinion" if kind == "ext28" else "ring"
    return model, next(g for g in model.gears if g.name == name)


def run_case(case: str) -> dict:
    """In this process: mesh, factorise and solve one flank's influence coefficients of the case's gear."""
    from hacgear_core.geometry import gear_geometry
    from hacgear_core.statics import fe as fe_mod

    with tempfile.TemporaryDirectory() as tmp:
        model, gear = _case_model(case, Path(tmp))
        gg = gear_geometry(gear)
        mode = model.statics.fe_lengths
        opts = fe_mod.gear_mesh_options(gear, mode)
        mat = fe_mod.ElasticMaterial(gear.material.youngs_modulus_Pa, gear.material.poisson_ratio)
        rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        t0 = time.perf_counter()
        c = fe_mod.gear_compliance(gg, mat, "drive", options=opts, cache=False, **fe_mod.compliance_lengths(gear, mode))
        wall = time.perf_counter() - t0
    return dict(case=case, teeth=gear.teeth, internal=gear.internal, normal_module_mm=gear.iso.normal_module_m * 1e3,
                fe_lengths=mode, flank_size_mm=opts.flank_size_m * 1e3, body_size_mm=opts.body_size_m * 1e3,
                n_dofs=int(c.info["n_dofs"]), n_triangles=int(c.info["n_triangles"]), flank_samples=int(c.s_m.size),
                wall_s=wall, peak_rss_MB=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                rss_before_build_MB=rss0 / 1024)


def _in_subprocess(*args: str) -> dict:
    out = subprocess.run([sys.executable, __file__, *args], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_statics(shared: bool) -> dict:
    """compute_statics of the module-45 pair, 2 workers, cold cache; ``shared``: with the one-build-per-gear step."""
    import psutil

    from hacgear_core.statics import grid

    if not shared:
        grid.prebuild_compliances = lambda *a, **k: {}    # as before: every worker builds what its solvers need
    me = psutil.Process()
    peak = [0]
    stop = threading.Event()

    def sample():
        while not stop.is_set():
            total = 0
            for p in [me, *me.children(recursive=True)]:
                try:
                    total += p.memory_info().rss
                except psutil.Error:
                    pass
            peak[0] = max(peak[0], total)
            time.sleep(0.02)

    with tempfile.TemporaryDirectory() as tmp:
        os.environ["HACGEAR_CACHE_DIR"] = str(Path(tmp) / "cache")
        (Path(tmp) / "model.toml").write_text(pair_toml(45.0))
        th = threading.Thread(target=sample, daemon=True)
        th.start()
        t0 = time.perf_counter()
        rep = grid.compute_statics(Path(tmp) / "model.toml", Path(tmp) / "tables.h5", positions=4, loads=2,
                                   deflections=4, workers=2, progress=False)
        wall = time.perf_counter() - t0
        stop.set()
        th.join()
    return dict(shared=shared, complete=bool(rep.success), wall_s=wall, peak_tree_rss_MB=peak[0] / 2 ** 20)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--absolute", action="store_true", help="also the module-10 pinion with the absolute lengths")
    ap.add_argument("--statics", action="store_true", help="also the statics worker-sharing measurement")
    ap.add_argument("--json", default="", help="write all numbers here")
    ap.add_argument("--case", default="", help=argparse.SUPPRESS)
    ap.add_argument("--statics-run", default="", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.case:
        print(json.dumps(run_case(args.case)))
        return
    if args.statics_run:
        print(json.dumps(run_statics(args.statics_run == "shared")))
        return
    print(f"CPU the kernels are compiled for: {vector_units().describe()}", flush=True)
    rows = []
    print(f"{'case':22s} {'z':>3s} {'m_n mm':>7s} {'lengths':>8s} {'flank mm':>9s} {'DOF':>8s} {'samples':>7s} "
          f"{'build s':>8s} {'peak RSS MB':>11s}")
    for case in CASES + (("ext28_m10_absolute",) if args.absolute else ()):
        r = _in_subprocess("--case", case)
        rows.append(r)
        print(f"{case:22s} {r['teeth']:3d} {r['normal_module_mm']:7g} {r['fe_lengths']:>8s} {r['flank_size_mm']:9.4g} "
              f"{r['n_dofs']:8d} {r['flank_samples']:7d} {r['wall_s']:8.2f} {r['peak_rss_MB']:11.1f}", flush=True)
    verdict = {}
    for gear in ("ext28", "int56"):
        group = [r for r in rows if r["case"] in CASES and r["case"].startswith(gear)]
        for key in ("n_dofs", "peak_rss_MB"):
            v = [r[key] for r in group]
            ratio = max(v) / min(v)
            verdict[f"{gear}.{key}"] = dict(ratio_max_min=ratio, within_20_percent=ratio <= 1.2)
            modules = ", ".join(f"{r['normal_module_mm']:g}" for r in group)
            print(f"{gear} {key}: max/min over modules {modules} mm = {ratio:.4f} "
                  f"({'within' if ratio <= 1.2 else 'OUTSIDE'} ±20 %)")
    stat = []
    if args.statics:
        for shared in (False, True):
            s = _in_subprocess("--statics-run", "shared" if shared else "per-worker")
            stat.append(s)
            print(f"statics module-45 pair 4x2x4 both sides, 2 workers, cold cache, FE "
                  f"{'built once before the workers' if shared else 'built in the workers (before)'}: "
                  f"{s['wall_s']:.1f} s, peak summed RSS {s['peak_tree_rss_MB']:.0f} MB, complete {s['complete']}",
                  flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(dict(cpu=vector_units().describe(), cases=rows, verdict=verdict,
                                                   statics=stat), indent=1))


if __name__ == "__main__":
    main()

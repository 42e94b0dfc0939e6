"""Figure of one mesh's geometry (``hacgear plot-geometry``).

Top: a few teeth of both gears of one mesh at a mesh position (loaded flanks touching at the pitch
point), base / tip / operating pitch circles, the line of action with the points A (start of
active contact), B (LPSTC of gear a), C (pitch point), D (HPSTC of gear a), E (end of contact).
Bottom: (left) one tooth of gear a with the profile deviation from the true involute (tip relief)
multiplied by K; (middle) tip relief [µm] against roll angle [deg] for both gears with the SAP,
LPSTC, HPSTC, EAP roll angles; (right) lead crowning [µm] across the face of both gears.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hacgear_core.geometry import REGION_INVOLUTE, SIDES, gear_geometry, mesh_geometry  # noqa: E402
from hacgear_core.geometry.train import place_mesh  # noqa: E402
from hacgear_core.outpaths import save_figure  # noqa: E402

__all__ = ["plot_mesh_geometry", "mesh_geometry_figure", "mesh_position"]


def _rot(xy: np.ndarray, ang: float) -> np.ndarray:
    c, s = math.cos(ang), math.sin(ang)
    return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)


def mesh_position(ga: Any, gb: Any, mg: Any) -> dict:
    """Placement of both gears of one mesh for the figure (:func:`hacgear_core.geometry.train.place_mesh`): gear a
    at the origin turning in the sense its loaded flank gives, the pitch point on +x, tooth 0 of each gear
    touching with its loaded flank at the pitch point.

    Returns ``centre_b`` (2,), ``phi_a``/``phi_b`` rotations [rad], ``pitch`` (2,), ``n`` (unit line-of-action
    vector = outward normal of gear a's loaded flank at the pitch point), ``t_a`` (gear a's base tangent point)
    and ``xi`` (function: line-of-action coordinate from ``t_a`` [m] -> point).
    """
    a = mg.center_distance_m
    sense_a = 1.0 if mg.flank_a == "drive" else -1.0
    # line of centres along +x, except for a pinion inside a ring, whose pitch point lies away from the ring centre
    e = -1.0 if (mg.internal and gb.internal) else 1.0
    pl = place_mesh(ga, gb, mg, sense_a, np.zeros(2), np.array([e * a, 0.0]))
    n = pl["line_of_action"]
    pitch = pl["pitch_point_m"]
    rb_a = ga.base_radius_m[mg.flank_a]
    u_w = math.tan(mg.operating_pressure_angle_rad)
    sg = 1.0 if not ga.internal else -1.0
    t_a = pitch - sg * rb_a * u_w * n

    def xi(v: Any) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        return t_a + sg * v[..., None] * n

    return dict(centre_b=np.array([e * a, 0.0]), phi_a=pl["angle_a"], phi_b=pl["angle_b"], pitch=pitch, n=n,
                xi=xi, t_a=t_a)


def _disp(xy: np.ndarray) -> np.ndarray:
    """Display frame: rotate by +90 deg so that the line of centres is vertical."""
    xy = np.asarray(xy, dtype=float)
    return np.stack([-xy[..., 1], xy[..., 0]], axis=-1)


def _teeth(gg: Any, phi: float, centre: np.ndarray, toward: float, count: int, n: int = 60):
    tb = gg.tooth_boundary(n).xy
    pitch = 2 * math.pi / gg.z
    out = []
    k0 = round((toward - phi) / pitch)
    for k in range(k0 - count, k0 + count + 1):
        out.append(_rot(tb, phi + k * pitch) + centre)
    return np.concatenate(out)


def plot_mesh_geometry(model: Any, mesh_name: str | None, out: str | Path, exaggerate: float | None = None) -> Path:
    """Draw the figure described in the module docstring (:func:`mesh_geometry_figure`) into ``out``; returns
    the output path."""
    fig = mesh_geometry_figure(model, mesh_name, exaggerate)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, out, dpi=110)
    plt.close(fig)
    return out


def mesh_geometry_figure(model: Any, mesh_name: str | None, exaggerate: float | None = None) -> Any:
    """The figure described in the module docstring (matplotlib Figure)."""
    mesh = model.mesh(mesh_name)
    ga, gb = gear_geometry(model.gear(mesh.gear_a)), gear_geometry(model.gear(mesh.gear_b))
    mg = mesh_geometry(model, mesh.name, gears={ga.name: ga, gb.name: gb}, strict=False)
    pos = mesh_position(ga, gb, mg)
    m = ga.module_m
    fig = plt.figure(figsize=(16, 12))
    gs = fig.add_gridspec(2, 3, height_ratios=[1.1, 1.0])
    ax = fig.add_subplot(gs[0, :])
    ks = 1e3  # plot in mm
    # teeth
    beta_b = math.atan2(pos["pitch"][1] - pos["centre_b"][1], pos["pitch"][0] - pos["centre_b"][0])
    ta = _teeth(ga, pos["phi_a"], np.zeros(2), 0.0, 3)
    tbp = _teeth(gb, pos["phi_b"], pos["centre_b"], beta_b, 3)
    # shade the material: close the teeth polyline through the gear centre (external) or far outside (internal)
    for g, poly, c, col in ((ga, ta, np.zeros(2), "tab:blue"), (gb, tbp, pos["centre_b"], "tab:red")):
        if not g.internal:
            closed = np.vstack([poly, c])
        else:
            far = [c + 3.0 * (poly[i] - c) for i in (-1, 0)]
            closed = np.vstack([poly, far[0], far[1]])
        q = _disp(closed)
        ax.fill(q[:, 0] * ks, q[:, 1] * ks, color=col, alpha=0.12, lw=0)
    ta, tbp = _disp(ta), _disp(tbp)
    ax.plot(ta[:, 0] * ks, ta[:, 1] * ks, color="tab:blue", lw=1.2, label=f"{ga.name} (z={ga.z})")
    ax.plot(tbp[:, 0] * ks, tbp[:, 1] * ks, color="tab:red", lw=1.2,
            label=f"{gb.name} (z={gb.z})")
    # circles (arcs near the mesh zone)
    span = 5 * math.pi * m

    def arc(centre, r, around, **kw):
        d = min(span / r, math.pi)
        t = np.linspace(around - d, around + d, 400)
        q = _disp(np.stack([centre[0] + r * np.cos(t), centre[1] + r * np.sin(t)], axis=1))
        ax.plot(q[:, 0] * ks, q[:, 1] * ks, **kw)

    for g, c, ar, col in ((ga, np.zeros(2), 0.0, "tab:blue"), (gb, pos["centre_b"], beta_b, "tab:red")):
        fl = mg.flank_a if g is ga else mg.flank_b
        arc(c, g.base_radius_m[fl], ar, color=col, ls="--", lw=0.8)
        arc(c, g.tip_radius_m, ar, color=col, ls=":", lw=0.8)
        arc(c, mg.operating_pitch_radius_m[g.name], ar, color=col, ls="-.", lw=0.5)
        arc(c, g.form_radius_m[fl], ar, color=col, ls=(0, (1, 3)), lw=0.6)
    # line of action
    xi = lambda v: _disp(pos["xi"](v))  # noqa: E731
    aff = mg._aff[gb.name]
    xi_tb = -aff[0] / aff[1]
    loa = xi(np.array([min(0.0, xi_tb), max(0.0, xi_tb)]))
    ax.plot(loa[:, 0] * ks, loa[:, 1] * ks, color="k", lw=0.8, ls="--", label="line of action (T1 T2)")
    act = xi(np.array([mg.contact_start_m, mg.contact_end_m]))
    ax.plot(act[:, 0] * ks, act[:, 1] * ks, color="k", lw=3, alpha=0.6, label="path of contact")
    pb = mg.base_pitch_m
    pts = {"A": mg.contact_start_m, "B": mg.contact_end_m - pb, "D": mg.contact_start_m + pb,
           "E": mg.contact_end_m}
    for lab, v in pts.items():
        p = xi(np.array(v))
        ax.plot(p[0] * ks, p[1] * ks, "ko", ms=5)
        ax.annotate(lab, (p[0] * ks, p[1] * ks), textcoords="offset points", xytext=(6, -12), fontsize=11)
    pp = _disp(pos["pitch"])
    ax.plot(pp[0] * ks, pp[1] * ks, "k+", ms=12, mew=2)
    ax.annotate("C", (pp[0] * ks, pp[1] * ks), textcoords="offset points", xytext=(6, 6), fontsize=11)
    for lab, v in (("T1", 0.0), ("T2", xi_tb)):
        p = xi(np.array(v))
        ax.plot(p[0] * ks, p[1] * ks, "k^", ms=6)
        ax.annotate(lab, (p[0] * ks, p[1] * ks), textcoords="offset points", xytext=(6, 4), fontsize=9)
    c = pp
    w, h = 2.3 * math.pi * m, 3.4 * m
    ax.set_xlim((c[0] - w) * ks, (c[0] + w) * ks)
    ax.set_ylim((c[1] - h) * ks, (c[1] + h) * ks)
    ax.set_aspect("equal")
    ra = mg.roll_angle_deg
    ax.set_title(
        f"{model.name}: mesh {mg.name}, a = {mg.center_distance_m * 1e3:.3f} mm, α_w = "
        f"{math.degrees(mg.operating_pressure_angle_rad):.3f}°, contact ratio {mg.contact_ratio:.3f} (loaded "
        f"{mg.flank_a}/{mg.flank_b}), {mg.contact_ratio_coast:.3f} (other flank)"
        + (f", face {mg.face_contact_ratio:.3f}" if mg.face_contact_ratio > 0 else "")
        + f"\nroll angles [°] {ga.name}: SAP {ra[ga.name]['SAP']:.2f}, EAP {ra[ga.name]['EAP']:.2f};  {gb.name}: "
        f"SAP {ra[gb.name]['SAP']:.2f}, EAP {ra[gb.name]['EAP']:.2f}.  Dashed: base, dotted: tip, dash-dot: "
        "operating pitch, fine dots: involute form circles", fontsize=10)
    ax.set_xlabel("across the line of centres [mm]")
    ax.set_ylabel(f"along the line of centres [mm] ({ga.name} centre at 0)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=9)  # outside: never on a tooth
    # --- exaggerated modifications on one tooth of gear a -----------------------------------
    ax2 = fig.add_subplot(gs[1, 0])
    mods = []
    for s in SIDES:
        f = ga.flank(s, 300)
        mods.append(f.modification_m.max())
    mmax = max(mods)
    k = exaggerate if exaggerate is not None else (0.3 * m / mmax if mmax > 0 else 1.0)
    ends = []
    for s, col in (("coast", "tab:green"), ("drive", "tab:purple")):
        f = ga.flank(s, 300)
        true = f.xy + f.modification_m[:, None] * f.normal
        exag = true - k * f.modification_m[:, None] * f.normal
        ax2.plot(true[:, 1] * ks, true[:, 0] * ks, color="0.5", lw=1, ls="--")
        ax2.plot(exag[:, 1] * ks, exag[:, 0] * ks, color=col, lw=1.5, label=f"{s} flank (relief × {k:.0f})")
        inv = f.region == REGION_INVOLUTE
        u0 = ga._flanks[s].relief_start
        if ga._flanks[s].relief > 0:
            j = np.argmin(np.abs(np.where(inv, f.roll_angle_rad, np.inf) - u0))
            ax2.plot(true[j, 1] * ks, true[j, 0] * ks, "o", color=col, ms=5)
        ends.append(exag[-1])
    ax2.plot([ends[0][1] * ks, ends[1][1] * ks], [ends[0][0] * ks, ends[1][0] * ks], color="k", lw=1)
    ax2.plot([], [], color="0.5", ls="--", label="true involute / fillet")
    ax2.set_aspect("equal")
    ax2.set_title(f"{ga.name}: tooth with deviations × K (dots: relief start)", fontsize=10)
    ax2.set_xlabel("tangential position [mm]")
    ax2.set_ylabel("radius [mm]")
    ax2.legend(fontsize=8, loc="lower center")
    # --- relief vs roll angle --------------------------------------------------------------
    ax3 = fig.add_subplot(gs[1, 1])
    # gear a wide and pale under gear b thin: identical curves (equal gears) stay visible as two
    for g, fl, col, lw, alpha in ((ga, mg.flank_a, "tab:blue", 4.0, 0.45), (gb, mg.flank_b, "tab:red", 1.3, 1.0)):
        for s, ls in ((fl, "-"), ("coast" if fl == "drive" else "drive", ":")):
            u = np.linspace(min(g.form_roll_rad[s], g.tip_roll_rad[s]), max(g.form_roll_rad[s], g.tip_roll_rad[s]),
                            300)
            ax3.plot(np.degrees(u), g.relief_m(s, u) * 1e6, color=col, ls=ls, lw=lw, alpha=alpha,
                     label=f"{g.name} {s}" + (" (loaded)" if s == fl else ""))
        for key, mk in (("SAP", "|"), ("LPSTC", "v"), ("HPSTC", "^"), ("EAP", "|")):
            big = g is ga
            ax3.plot(ra[g.name][key], 0, mk, color=col, alpha=alpha, mew=2.5 if big else 1.2,
                     ms=(16 if mk == "|" else 11) if big else (10 if mk == "|" else 6))
    ax3.set_xlabel("roll angle [°]  (markers on the axis: SAP, LPSTC (v), HPSTC (^), EAP)")
    ax3.set_ylabel("tip relief [µm]")
    ax3.set_title("profile modification (tip relief)", fontsize=10)
    ax3.grid(alpha=0.3)
    ax3.legend(fontsize=8)
    # --- crowning ------------------------------------------------------------------------
    ax4 = fig.add_subplot(gs[1, 2])
    for g, col, lw, alpha in ((ga, "tab:blue", 4.0, 0.45), (gb, "tab:red", 1.3, 1.0)):
        zz = np.linspace(-g.face_width_m / 2, g.face_width_m / 2, 101)
        ax4.plot((zz + g.axial_position_m) * 1e3, g.crowning_m(zz) * 1e6, color=col, lw=lw, alpha=alpha,
                 label=f"{g.name}: {g.lead_crowning_m * 1e6:.1f} µm, b = {g.face_width_m * 1e3:.1f} mm"
                 + (f", helix {math.degrees(g.helix_angle_rad):.1f}°" if g.helix_angle_rad else ""))
    ax4.set_xlabel("axial position [mm]")
    ax4.set_ylabel("lead crowning [µm]")
    ax4.set_title("lead modification (crowning)", fontsize=10)
    ax4.grid(alpha=0.3)
    ax4.legend(fontsize=8)
    if mg.warnings:
        fig.text(0.01, 0.005, "warnings: " + " | ".join(mg.warnings)[:400], fontsize=7, color="darkred")
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    return fig

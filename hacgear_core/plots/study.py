"""Pictures of a study results file: the Harris map (static transmission error peak-to-peak over torque, one curve
per variant), the dynamic map (force dynamic factor and peak root strain over mesh frequency x variant at each sweep
torque, heat maps with the confirmed jumps marked) and the best variant per criterion over the study's load spectrum."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from hacgear_core.errors import TableError  # noqa: E402
from hacgear_core.outpaths import save_figure  # noqa: E402
from hacgear_core.studies import best_variants, read_study  # noqa: E402
from hacgear_core.studies.design import StudyResults  # noqa: E402

__all__ = ["harris_map", "dynamic_map", "best_variant_chart", "plot_study_file", "variable_name", "criterion_label",
           "METRIC_LABELS"]


#: units of study variables and metrics as a figure shows them
_UNITS = {"um": "µm", "Nm": "N·m", "N*m": "N·m", "-": "", "deg": "°", "mm": "mm", "Pa": "Pa", "m": "m", "N/m": "N/m"}
#: unit suffixes of model keys, removed from a variable's short name (its unit is shown with the value)
_KEY_UNITS = ("_um", "_mm", "_Nm", "_deg", "_kg", "_GPa", "_N_per_m", "_Nm_per_rad", "_kg_per_m3", "_kgm2")
#: readable names of the study metrics and criteria (the results file's keys are Python names)
METRIC_LABELS = {
    "ste_peak_to_peak_m": "static TE, peak-to-peak",
    "max_root_strain": "peak static root strain",
    "max_contact_pressure_Pa": "peak static contact pressure",
    "mean_mesh_stiffness_N_per_m": "mean mesh stiffness",
    "mesh_force_N": "static mesh force",
    "dynamic_factor_force": "force dynamic factor",
    "dynamic_factor_strain": "strain dynamic factor",
    "peak_root_strain": "peak dynamic root strain",
    "contact_loss_fraction": "contact loss",
    "rms_deflection_m": "RMS mesh deflection",
}


def variable_name(key: str) -> str:
    """Short name of a study variable's key path: its last segment without the unit suffix, with the gear or mesh
    a selector names (``gears[*].drive.tip_relief_um`` → ``tip relief``, ``gears[wheel].lead_crowning_um`` →
    ``wheel lead crowning``)."""
    parts = key.split(".")
    leaf = parts[-1]
    for suffix in _KEY_UNITS:
        if leaf.endswith(suffix):
            leaf = leaf[: -len(suffix)]
            break
    names = [p.split("[", 1)[1].rstrip("]") for p in parts if "[" in p]
    named = [n for n in names if n not in ("*",) and not n.isdigit()]
    flank = [p for p in parts[:-1] if p in ("drive", "coast")]
    words = named + (["coast"] if flank == ["coast"] else []) + [leaf.replace("_", " ")]
    return " ".join(words)


def _unit(u: str) -> str:
    return _UNITS.get(u, u)


def _value(v: dict, x) -> str:
    unit = _unit(v["unit"])
    return (f"{x:g} {unit}".strip() if isinstance(x, float) else str(x))


def _short(res: StudyResults, i: int) -> str:
    """A variant's label: its value with the unit when one variable (``30 µm``), else each variable's short name
    and value (``tip relief 30 µm, lead crowning 15 µm``)."""
    if len(res.variables) == 1:
        return _value(res.variables[0], res.variables[0]["values"][i])
    return ", ".join(f"{variable_name(v['key'])} {_value(v, v['values'][i])}" for v in res.variables)


def _title_key(res: StudyResults) -> str:
    """The variables, by short name and unit (``tip relief [µm]``)."""
    return ", ".join(f"{variable_name(v['key'])}" + (f" [{_unit(v['unit'])}]" if _unit(v["unit"]) else "")
                     for v in res.variables)


def criterion_label(name: str) -> str:
    """``spectrum_mean_ste_peak_to_peak_m`` → ``static TE, peak-to-peak: load-spectrum mean``."""
    for prefix, how in (("spectrum_mean_", "load-spectrum mean"), ("sweep_max_", "largest over the sweep")):
        if name.startswith(prefix):
            m = name[len(prefix):]
            return f"{METRIC_LABELS.get(m, m.replace('_', ' '))}: {how}"
    return METRIC_LABELS.get(name, name.replace("_", " "))


def harris_map(res: StudyResults):
    """Static transmission error peak-to-peak [µm] over torque [N m], one curve per finished variant."""
    n = len(res.labels)
    fig, ax = plt.subplots(figsize=(8.0, 4.6 + 0.18 * n), layout="constrained")
    cmap = plt.get_cmap("viridis")
    for i in range(n):
        if not res.done[i]:
            continue
        ax.plot(res.torque_Nm, res.static["ste_peak_to_peak_m"][i] * 1e6, "o-", color=cmap(i / max(n - 1, 1)),
                label=_short(res, i))
    ax.set_xlabel("torque [N·m]")
    ax.set_ylabel("static transmission error, peak-to-peak [µm]")
    ax.set_title(f"Harris map: {res.name}")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(title=_title_key(res), fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def dynamic_map(res: StudyResults):
    """Heat maps over mesh frequency [Hz] x variant: force dynamic factor [-] and peak root strain [µε], one column
    per sweep branch, one pair of rows per sweep torque [N m]; confirmed jumps marked (▲ jump-up, ▼ jump-down) on
    their variant's row.  Each metric has one colour scale over all torques and branches."""
    branches = list(res.dynamic)
    nd = res.dynamic_torque_Nm.shape[1]
    n = len(res.labels)
    labels = [_short(res, i) for i in range(n)]
    # panels grow with the variants (rows of the heat map) and the label width; at least 2.6 in tall
    row_h = max(2.6, 0.32 * n + 1.4)
    label_w = 0.065 * max(len(t) for t in labels)
    fig, axes = plt.subplots(2 * nd, len(branches), figsize=(5.8 * len(branches) + label_w + 1.2, row_h * 2 * nd),
                             squeeze=False, sharex=True, layout="constrained")
    f = res.frequency_Hz
    df = np.diff(f).mean() if f.size > 1 else 1.0
    edges_f = np.concatenate([f - df / 2, [f[-1] + df / 2]])
    edges_v = np.arange(n + 1) - 0.5
    metrics = (("dynamic_factor_force", 1.0, "force dynamic factor [-]", "magma"),
               ("peak_root_strain", 1e6, "peak root strain [µε]", "viridis"))
    for r, (metric, scale, label, cmap) in enumerate(metrics):
        vals = [np.where(res.done[:, None, None], res.dynamic[b][metric] * scale, np.nan) for b in branches]
        lo = min(np.nanmin(v) for v in vals)
        hi = max(np.nanmax(v) for v in vals)
        for d in range(nd):
            torque = np.nanmax(res.dynamic_torque_Nm[:, d]) if np.any(np.isfinite(res.dynamic_torque_Nm[:, d])) \
                else float("nan")
            for c, b in enumerate(branches):
                ax = axes[2 * d + r, c]
                mesh = ax.pcolormesh(edges_f, edges_v, vals[c][:, d], cmap=cmap, vmin=lo, vmax=hi, shading="flat")
                for i, per_torque in enumerate(res.jumps):
                    for j in per_torque[d]:
                        if j["branch"] == b:
                            ax.plot(j["frequency_Hz"], i, "^" if j["kind"] == "jump-up" else "v", color="cyan",
                                    mec="k", ms=9)
                if c == 0:   # the rows are the same variants in every column: named once, at the left
                    ax.set_yticks(range(n), labels, fontsize=8 if n <= 12 else 6)
                    ax.set_ylabel(_title_key(res))
                else:
                    ax.set_yticks(range(n), [])
                ax.set_title(f"{label.split(' [')[0]}, {b} sweep at {torque:g} N·m", fontsize=10)
                ax.xaxis.set_major_locator(MaxNLocator(nbins=5))
                fig.colorbar(mesh, ax=ax, label=label, pad=0.02)
                if 2 * d + r == 2 * nd - 1:
                    ax.set_xlabel("mesh frequency [Hz]")
    fig.suptitle(f"dynamic map: {res.name} (▲/▼ confirmed jump-up / jump-down)")
    return fig


def best_variant_chart(res: StudyResults):
    """Per criterion (:func:`~hacgear_core.studies.best_variants`) every variant's value relative to the best (1 =
    best), the best one outlined and named under the criterion."""
    best = best_variants(res)
    names = list(best)
    n = len(res.labels)
    fig, ax = plt.subplots(figsize=(9.5, 1.8 + 0.9 * len(names) + 0.2 * n), layout="constrained")
    h = 0.8 / n
    cmap = plt.get_cmap("viridis")
    for c, name in enumerate(names):
        b = best[name]
        vals = np.array([np.nan if v is None else v for v in b["values"]]) / b["value"]
        for i in range(n):
            y = c + (i - (n - 1) / 2) * h
            ax.barh(y, vals[i], height=h * 0.9, color=cmap(i / max(n - 1, 1)),
                    edgecolor="k" if i == b["index"] else "none", linewidth=2.0)
    ax.set_yticks(range(len(names)), [f"{criterion_label(s)}\nbest: {_short(res, best[s]['index'])}" for s in names],
                  fontsize=8)
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_xlabel("value / best value [-]   (outlined: the best variant)")
    spec = res.spec
    if spec.get("spectrum_torques_Nm"):
        sp = ", ".join(f"{t:g} N·m {w * 100:.0f} %"
                       for t, w in zip(spec["spectrum_torques_Nm"], spec["spectrum_weights"]))
    else:
        sp = "static torques, equal shares"
    ax.set_title(f"best variant per criterion ({sp})", fontsize=9)
    handles = [Patch(color=cmap(i / max(n - 1, 1)), label=_short(res, i)) for i in range(n)]
    fig.legend(handles=handles, title=_title_key(res), fontsize=7, title_fontsize=8, loc="outside lower center",
               ncol=min(n, 2 if len(res.variables) > 1 else 4), frameon=False)
    ax.invert_yaxis()
    return fig


def plot_study_file(path: str | Path, out: str | Path) -> list[Path]:
    """Write the Harris map to ``out``, the dynamic map (when the study has sweeps) to ``<out stem>_dynamic<suffix>``
    and the best-variant chart to ``<out stem>_best<suffix>``; returns the files written."""
    res = read_study(path)
    if not np.any(res.done):
        raise TableError(f"{path}: no finished variant to plot")
    out = Path(out)
    written = []
    for fig_fn, target in ((harris_map, out), (dynamic_map, out.with_name(f"{out.stem}_dynamic{out.suffix}")),
                           (best_variant_chart, out.with_name(f"{out.stem}_best{out.suffix}"))):
        if fig_fn is dynamic_map and not res.dynamic:
            continue
        fig = fig_fn(res)
        save_figure(fig, target, dpi=110)
        plt.close(fig)
        written.append(target)
    return written

"""Pictures of a study results file: the Harris map (static transmission error peak-to-peak over torque, one curve
per variant), the dynamic map (force dynamic factor and peak root strain over mesh frequency x variant at each sweep
torque, heat maps with the confirmed jumps marked) and the best variant per criterion over the study's load spectrum."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hacgear_core.errors import TableError  # noqa: E402
from hacgear_core.studies import best_variants, read_study  # noqa: E402
from hacgear_core.studies.design import StudyResults  # noqa: E402

__all__ = ["harris_map", "dynamic_map", "best_variant_chart", "plot_study_file"]


def _short(res: StudyResults, i: int) -> str:
    """A variant's legend label: its values with the variables' units (``tip_relief_um=30`` → ``30 um``) when one
    variable, else its full label."""
    if len(res.variables) == 1:
        v = res.variables[0]
        x = v["values"][i]
        unit = {"um": "µm", "Nm": "N·m", "-": ""}.get(v["unit"], v["unit"])
        return f"{x:g} {unit}".strip() if isinstance(x, float) else str(x)
    return res.labels[i]


def _title_key(res: StudyResults) -> str:
    return ", ".join(v["key"] for v in res.variables)


def harris_map(res: StudyResults):
    """Static transmission error peak-to-peak [µm] over torque [N m], one curve per finished variant."""
    fig, ax = plt.subplots(figsize=(8.0, 4.6))
    cmap = plt.get_cmap("viridis")
    n = len(res.labels)
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
    fig.tight_layout()
    return fig


def dynamic_map(res: StudyResults):
    """Heat maps over mesh frequency [Hz] x variant: force dynamic factor [-] and peak root strain [µε], one column
    per sweep branch, one pair of rows per sweep torque [N m]; confirmed jumps marked (▲ jump-up, ▼ jump-down) on
    their variant's row.  Each metric has one colour scale over all torques and branches."""
    branches = list(res.dynamic)
    nd = res.dynamic_torque_Nm.shape[1]
    fig, axes = plt.subplots(2 * nd, len(branches), figsize=(6.0 * len(branches), 3.5 * 2 * nd), squeeze=False,
                             sharex=True)
    f = res.frequency_Hz
    df = np.diff(f).mean() if f.size > 1 else 1.0
    n = len(res.labels)
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
                ax.set_yticks(range(n), [_short(res, i) for i in range(n)])
                ax.set_ylabel(_title_key(res) if len(res.variables) == 1 else "variant")
                ax.set_title(f"{label.split(' [')[0]}, {b} sweep at {torque:g} N·m")
                fig.colorbar(mesh, ax=ax, label=label)
                if 2 * d + r == 2 * nd - 1:
                    ax.set_xlabel("mesh frequency [Hz]")
    fig.suptitle(f"dynamic map: {res.name} (▲/▼ confirmed jump-up / jump-down)")
    fig.tight_layout()
    return fig


def best_variant_chart(res: StudyResults):
    """Per criterion (:func:`~hacgear_core.studies.best_variants`) every variant's value relative to the best (1 =
    best), the best one marked."""
    best = best_variants(res)
    names = list(best)
    n = len(res.labels)
    fig, ax = plt.subplots(figsize=(9.5, 0.8 + 0.9 * len(names)))
    h = 0.8 / n
    cmap = plt.get_cmap("viridis")
    for c, name in enumerate(names):
        b = best[name]
        vals = np.array([np.nan if v is None else v for v in b["values"]]) / b["value"]
        for i in range(n):
            y = c + (i - (n - 1) / 2) * h
            ax.barh(y, vals[i], height=h * 0.9, color=cmap(i / max(n - 1, 1)),
                    label=_short(res, i) if c == 0 else None, edgecolor="k" if i == b["index"] else "none",
                    linewidth=2.0)
        ax.annotate(f"best: {_short(res, b['index'])}", (float(np.nanmax(vals)) * 1.02, c), fontsize=8, ha="left",
                    va="center")
    ticks = [s.replace("spectrum_mean_", "spectrum mean: ").replace("sweep_max_", "sweep max: ") for s in names]
    ax.set_yticks(range(len(names)), ticks, fontsize=8)
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_xlabel("value / best value [-]")
    spec = res.spec
    if spec.get("spectrum_torques_Nm"):
        sp = ", ".join(f"{t:g} N·m {w * 100:.0f} %"
                       for t, w in zip(spec["spectrum_torques_Nm"], spec["spectrum_weights"]))
    else:
        sp = "static torques, equal shares"
    ax.set_title(f"best variant per criterion ({sp})", fontsize=9)
    ax.legend(title=_title_key(res), fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_xlim(0, ax.get_xlim()[1] * 1.15)
    ax.invert_yaxis()
    fig.tight_layout()
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
        fig.savefig(target, dpi=110)
        plt.close(fig)
        written.append(target)
    return written

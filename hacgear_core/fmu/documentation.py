"""An FMU's ``documentation/index.html`` and its coupling diagram, generated from the FMU's variable spec."""
from __future__ import annotations

import html
import math
import re

from hacgear_core.fmu.spec import ENUMERATIONS, ident, output_getters, variables_table

__all__ = ["coupling_diagram", "calculated_values", "documentation_html", "documented_names", "readme_block",
           "DOCUMENTATION_FILE"]

#: where FMI 2.0 and 3.0 put an FMU's documentation (its entry point)
DOCUMENTATION_FILE = "documentation/index.html"


def _ports(adapter) -> tuple[str, list[str]]:
    """(input port, the other ports) of a gear system's adapter, by their FMU identifiers."""
    inp = adapter.spec_system.input_gear
    return ident(inp), [ident(g) for g in adapter.ports if g != inp]


def coupling_diagram(adapter, values: dict | None = None) -> str:
    """Plain-text diagram of a gear system FMU coupled in drivetrain mode (``mode`` = 1): the input port on the
    left, the other ports on the right, each shaft end giving a torque [N.m] and receiving the gear's angle [rad]
    and speed [rad/s]; ``values``: calculated parameters shown in the box (:func:`calculated_values`)."""
    values = values or {}
    left, right = _ports(adapter)

    def arm(p: str, side: str) -> list[str]:
        if side == "left":
            return [f"--{p}.torque_in [N.m]-->", f"<--{p}.speed [rad/s]-----", f"<--{p}.angle [rad]-------"]
        return [f"<--{p}.torque_in [N.m]--", f"---{p}.speed [rad/s]---->", f"---{p}.angle [rad]------>"]

    box = [adapter.model.name, "mode = 1 (drivetrain)"]
    if "gear_ratio" in values:
        box.append(f"gear_ratio = {values['gear_ratio']:.6g}")
    if "drivetrain_step" in values:
        box.append(f"drivetrain_step = {values['drivetrain_step']:g} s")
    la = arm(left, "left")
    ra = [line for p in right for line in arm(p, "right") + [""]][:-1] if right else []
    rows = max(len(box), len(la), len(ra)) + 0
    width = max(len(b) for b in box) + 4
    lw = max(len(x) for x in la)
    out = [" " * (lw + 14) + "+" + "-" * width + "+"]
    for i in range(rows):
        lt = la[i] if i < len(la) else ""
        rt = ra[i] if i < len(ra) else ""
        src = "shaft/motor " if i == 0 else " " * 12
        dst = " shaft/load" if i == 0 or (rt.startswith("<--") and i > 0) else ""
        b = box[i] if i < len(box) else ""
        out.append(f"{src}{lt:<{lw}}  |  {b:<{width - 4}}  |  {rt}{dst if rt else ''}".rstrip())
    out.append(" " * (lw + 14) + "+" + "-" * width + "+")
    return "\n".join(out) + "\n"


def calculated_values(adapter) -> dict[str, float]:
    """The calculated parameters of a gear system's FMU at its start values (name -> value): what a master reads
    after initialization with the defaults."""
    variables = adapter.variables
    if getattr(adapter, "sim", None) is None or getattr(adapter, "_built_key", None) is None:
        adapter.configure({v.name: v.start for v in variables if v.start is not None})
    getters = output_getters(variables, adapter)
    return {v.name: float(getters[v.name]()) for v in variables if v.causality == "calculatedParameter"}


def readme_block(adapter) -> str:
    """What a model readme shows of its FMU (between :data:`~hacgear_core.fmu.spec.README_BEGIN` and
    ``README_END``): the drivetrain coupling diagram with the calculated parameters at the start values, then the
    variable table (:func:`~hacgear_core.fmu.spec.variables_table`)."""
    values = calculated_values(adapter)
    unit = {k: "" if adapter.by_name[k].unit == "1" else adapter.by_name[k].unit for k in values}
    listed = "; ".join(f"`{k}` = {v:.6g} {unit[k]}".rstrip() for k, v in values.items())
    return (f"Drivetrain coupling (`mode` = 1; docs/fmu.md, \"Drivetrain coupling\"):\n\n```\n"
            f"{coupling_diagram(adapter, values)}```\n\nCalculated parameters at the start values: {listed}.\n\n"
            + variables_table(adapter.variables))


def _num(x) -> str:
    if x is None:
        return ""
    if isinstance(x, float):
        return "inf" if x == math.inf else f"{x:.6g}"
    return str(x)


def _range(v) -> str:
    if v.declared_type:
        return ", ".join(f"{n} = {k}" for n, k, _ in ENUMERATIONS[v.declared_type][1])
    if v.min is None and v.max is None:
        return ""
    lo = _num(v.min) if v.min is not None else "-inf"
    hi = _num(v.max) if v.max is not None else "inf"
    return (f"{'(' if v.min_open else '['}{lo}, {hi}{')' if v.max_open else ']'}" + (" or inf" if v.allow_inf
                                                                                      else ""))


def _table(head: list[str], rows: list[list[str]]) -> str:
    e = html.escape
    th = "".join(f"<th>{e(h)}</th>" for h in head)
    body = "\n".join("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table>\n<tr>{th}</tr>\n{body}\n</table>\n"


_STATUSES = [
    ("OK", "the call did what it should."),
    ("Warning", "the call did it, but something deserves attention: an input the chosen experiment ignores was set "
                "to a value other than its start value (e.g. <code>&lt;port&gt;.torque_in</code> while "
                "<code>mode</code> = 0: set <code>mode</code> = 1 for a drivetrain coupling); said once, in the "
                "log."),
    ("Discard", "<code>doStep</code> could not complete the step (integration diverged, or the step would need "
                "more than 2e8 internal steps): the state is left at the step's start; reduce the communication step "
                "or the loads.  pythonfmu FMI 2.0 FMUs also answer every error of a <code>doStep</code> this way."),
    ("Error", "a wrong call or value: a parameter or input outside its range (the message names the variable, its "
              "unit and the range), an illegal call sequence, a foreign FMU state.  The instance is in its error "
              "state: free it or (FMI 3.0 and 2.0) reset it.  pythonfmu FMUs answer OK to such calls and report "
              "the Error at the next <code>doStep</code>."),
    ("Fatal", "never returned."),
]


def documentation_html(adapter, info: dict, fmi_version: int, backend: str) -> str:
    """``documentation/index.html`` of an FMU: what it is, its ports and how to couple them (gear systems), every
    variable with unit, range and meaning, the equations in brief, the runtime requirements and what each
    status means; all from the variable spec ``adapter.variables`` and the FMU's ``info``
    (``resources/hacgear_fmu.json``)."""
    e = html.escape
    name = info.get("system", "")
    variables = [v for v in adapter.variables if v.causality != "independent"]
    is_system = hasattr(adapter, "spec_system")
    calc = calculated_values(adapter) if is_system else {}
    req = info.get("requirements", {})
    py = info.get("python", "")
    parts = [
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n",
        f"<title>{e(name)}: hacgear FMU</title>\n",
        "<style>body{font-family:sans-serif;max-width:72em;margin:1em auto;line-height:1.4}"
        "table{border-collapse:collapse}td,th{border:1px solid #999;padding:2px 6px;vertical-align:top}"
        "pre{background:#f4f4f4;padding:6px;overflow-x:auto}</style>\n</head>\n<body>\n",
        f"<h1>{e(name)}</h1>\n<p>{e(str(info.get('description', '')))}</p>\n",
        _table(["", ""], [["FMI version", f"{fmi_version}.0 co-simulation"], ["backend", e(backend)],
                          ["kind", e(str(info.get("kind", "")))], ["generated by", f"hacgear {e(str(info.get('hacgear_version', '')))}"],
                          ["GUID / instantiation token", f"<code>{e(str(info.get('guid', '')))}</code>"]]),
    ]
    if is_system:
        left, right = _ports(adapter)
        ref = adapter.ref_ident
        parts += [
            "<h2>How to couple it</h2>\n",
            "<p><b>Drivetrain mode</b> (set the parameter <code>mode</code> = 1 before initialization): each port "
            "is a shaft end.  The master gives the shaft torque on each port gear "
            "(<code>&lt;port&gt;.torque_in</code> [N.m], positive in the gear's sense of rotation, a braking load "
            "negative) and reads back the gear's motion (<code>&lt;port&gt;.angle</code> [rad], "
            "<code>&lt;port&gt;.speed</code> [rad/s]) for its shaft model (a spring-damper between this gear and "
            "the motor or load inertia).  The initial speed is <code>" + e(ref) + ".speed_start</code>.</p>\n",
            f"<pre>{e(coupling_diagram(adapter, calc))}</pre>\n",
            "<p>Use a communication step no larger than <code>drivetrain_step</code> (a calculated parameter: 1/20 of "
            "the period of the highest natural frequency in which a port moves, and 1/10 of the mesh period at the "
            "start speed); a coarser step samples the port motion too seldom: spurious force peaks, states beyond "
            "the tables (<code>&lt;mesh&gt;.out_of_range</code>).  The calculated parameters say what a shaft "
            "coupled to a port sees:</p>\n",
            _table(["calculated parameter", "value at the start values", "unit"],
                   [[f"<code>{e(k)}</code>", f"{v:.8g}", e(adapter.by_name[k].unit)] for k, v in calc.items()]),
            "<p><b>Constant-speed mode</b> (<code>mode</code> = 0, the default: the dissertation's experiment, the "
            "FMU alone shows the mesh resonance): gear <code>" + e(adapter.ref) + "</code> turns at the input "
            "<code>" + e(ref) + ".speed_in</code> [rad/s]; the nominal torque <code>torque</code> [N.m] loads the "
            "train; the <code>&lt;port&gt;.torque_in</code> inputs are ignored (setting one gives a Warning).</p>\n",
            "<p><b>Energy.</b> In drivetrain mode the outputs close the balance "
            "<code>" + " + ".join(f"{p}.power" for p in [left] + right) + " &minus; dissipated_power = "
            "d(kinetic_energy + elastic_energy)/dt</code>; integrated over a run with the trapezoidal rule at "
            "<code>drivetrain_step</code> the residual is the work of the mesh stiffness's variation with mesh "
            "position (parametric excitation), a small fraction of the input work.</p>\n",
            "<h2>Equations in brief</h2>\n",
            "<p>The hybrid analytical-computational (HAC) method: a lumped model of the gear bodies "
            "(rotations; translations on the bearings) <code>M q'' + C q' + K q + sum_k f_k(tau_k, delta_k) = "
            "f</code>, where the mesh force <code>F_k(tau_k, delta_k)</code> of each mesh is read from tables "
            "computed once by static finite-element contact analyses over mesh position <code>tau</code> [mesh "
            "cycles] and mesh deflection <code>delta</code> [m] (force-deflection function; two-sided tables hold "
            "the coast flanks too), with root strains and contact pressures tabulated alike.  <code>C</code> is "
            "modal damping (<code>modal_damping_ratio</code> on every elastic mode of the model linearised at "
            "the nominal torque).  Integration: fixed-step RK4 no longer than <code>internal_step</code> "
            "(0: 1/128 of the mesh period and 1/32 of the highest natural period), sub-stepping each "
            "communication step.  F = 0 where the teeth separate (contact loss).</p>\n",
        ]
    parts += [
        "<h2>Variables</h2>\n",
        _table(["name", "causality", "type", "unit", "start", "range", "description"],
               [[f"<code>{e(v.name)}</code>", e(v.causality), e(v.declared_type or v.type),
                 e(v.unit + (f" (display {v.display_unit})" if v.display_unit else "")),
                 e(_num(v.start)), e(_range(v)), e(v.description)] for v in variables]),
        "<h2>What the importer needs</h2>\n<ul>\n",
        f"<li>A 64-bit Python &gt;= {e(py)} with "
        + ", ".join(f"{e(k)} &gt;= {e(str(v))}" for k, v in req.items())
        + " (the FMU's own hacgear code, model and tables travel inside it, under <code>resources/</code>).</li>\n",
    ]
    if backend == "native":
        parts.append("<li>Linux x86-64.  The binary loads the libpython of the first of: the Python named by the "
                     "environment variable <code>HACGEAR_FMU_PYTHON</code>, the interpreter recorded when the FMU "
                     "was built (<code>resources/hacgear_fmu.json</code>, <code>python_runtime</code>), a "
                     "<code>python3</code> (then <code>python</code>) on PATH that has the packages above.  That "
                     "Python needs a shared libpython.  No <code>LD_PRELOAD</code> needed.</li>\n")
    else:
        parts.append("<li>Linux x86-64 or Windows x64 (pythonfmu binaries).  On Windows: the Python's folder "
                     "(holding <code>python3.dll</code>) on PATH and the Microsoft Visual C++ 2015-2022 "
                     "Redistributable (x64) where <code>MSVCP140.dll</code> is missing.  In a Linux master that is "
                     "not a Python program set <code>LD_PRELOAD</code> (the Python's libpython), "
                     "<code>PYTHONHOME</code> (its installation prefix) and, for a virtual environment, "
                     "<code>PYTHONPATH</code> (its site-packages).</li>\n")
    parts += [
        "<li>The first <code>ExitInitializationMode</code> of a process compiles or loads the kernel "
        "(seconds); a numba cache folder next to the extracted FMU keeps it for later runs.</li>\n</ul>\n",
        "<h2>What each status means</h2>\n",
        _table(["status", "meaning"], [[f"<b>{s}</b>", m] for s, m in _STATUSES]),
        "<p>Every message names the variable, its unit and the allowed range where a value is refused; with "
        "debug logging off the FMU still logs warnings and errors.</p>\n",
        "</body>\n</html>\n",
    ]
    return "".join(parts)


def documented_names(text: str) -> set[str]:
    """Variable names listed in the variables table of a :func:`documentation_html` page."""
    return set(re.findall(r"<tr><td><code>([^<]+)</code></td><td>", text))

"""Natural frequencies and mode shapes of a lumped gear system: linearised modal analysis and the impulse test.

Linearised modal analysis
    ``(K + sum_k k_k v_k v_k^T) phi = omega^2 M phi`` with ``k_k`` the cycle mean of mesh ``k``'s force-law
    stiffness at its nominal static force (for ``hac`` the local slope of the FDF at the static deflection,
    dissertation Eq. 3.8's ``k_l`` averaged over the cycle).  Rigid-body rotation modes (omega = 0) are
    reported separately.

Impulse test (dissertation Section 3.6.1)
    The gears rest in static equilibrium under the nominal load at a fixed mesh position (no rotation); an
    angular-velocity impulse on the reference gear (and translational ones where translations exist) starts a
    free vibration of small amplitude (1 % of the static deflection), integrated with the same kernel and
    force law (undamped).  The natural frequencies are the peaks of the Blackman-windowed, zero-padded
    spectrum of the mesh deflections and translations.  This is done at a single- and at a double-tooth-contact
    position of the first mesh (middle of the longest run of positions with one resp. two loaded pairs at the
    static load; from ``tooth_load_N`` when the table has it, else from the local slope: below/above the cycle
    mean), and the frequencies are combined with the contact-ratio weights:
    ``f = (2 - eps) f_single + (eps - 1) f_double`` with ``eps`` = 1 + the fraction of the cycle in double
    contact.

Modes of a rotating (gyroscopic) system
    ``lambda^2 M phi + lambda W_c G phi + (K_lin - W_c^2 K_W) phi = 0`` (the quadratic eigenproblem of the
    undamped linearisation at carrier speed ``W_c``), solved in first-order form; the natural frequencies are
    ``Im(lambda) / 2 pi`` of the ``n`` roots with ``Im >= 0`` (rigid-body modes as 0).  Each mode is classified
    by where its motion is (Lin & Parker 1999): ``rotational`` (central members only rotate), ``translational``
    (central members only translate), ``planet`` (central members at rest), ``rigid`` (a free rotation), else
    ``mixed``; ``multiplicity`` counts equal frequencies of one type.  With identical, equally spaced planets
    and isotropic supports: rotational modes single, translational modes double (their split grows with
    ``W_c``), planet modes of multiplicity ``N - 3``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hacgear_core.dynamics.equilibrium import static_equilibrium
from hacgear_core.dynamics.system import LumpedSystem
from hacgear_core.errors import ModelError, SolverError
from hacgear_core.tables.fdf import contact_count, static_stiffness

__all__ = ["ModalResult", "ImpulseResult", "modal_analysis", "impulse_test", "contact_positions",
           "identical_pair_mass_properties", "GyroscopicModes", "gyroscopic_modes", "MODE_TYPES", "dominant_members"]

#: mode types of :func:`gyroscopic_modes`
MODE_TYPES = ("rigid", "rotational", "translational", "planet", "mixed")


@dataclass
class ModalResult:
    """Elastic modes of the linearised system: ``natural_frequencies_Hz`` ascending, ``mode_shapes``
    (n_dof, n_modes) scaled to max |component| = 1 (rotations as r_b * theta [m], counter-clockwise, so
    components compare), ``dof_names``, ``mesh_stiffness_N_per_m`` (m,) per mesh, ``rigid_body_modes``."""

    natural_frequencies_Hz: np.ndarray
    mode_shapes: np.ndarray
    dof_names: tuple
    mesh_stiffness_N_per_m: np.ndarray
    rigid_body_modes: int
    mesh_names: tuple = ()

    def to_json(self) -> dict:
        return {
            "natural_frequencies_Hz": self.natural_frequencies_Hz.tolist(),
            "mode_shapes": {"dof_names": list(self.dof_names),
                            "note": "one row per mode; rotations given as r_b*theta [m], counter-clockwise",
                            "shapes": self.mode_shapes.T.tolist()},
            "mesh_stiffness_N_per_m": dict(zip(self.mesh_names, np.atleast_1d(self.mesh_stiffness_N_per_m).tolist())),
            "rigid_body_modes": self.rigid_body_modes,
        }


def modal_analysis(system: LumpedSystem) -> ModalResult:
    """Linearised modal analysis of ``system`` at its nominal torque (see module docstring)."""
    omega = system.modal_omega
    phi = system.modal_shapes
    el = ~system.rigid_modes
    order = np.argsort(omega[el])
    w = omega[el][order]
    shapes = phi[:, el][:, order].copy()
    # rotations as arc length on the base circle so that components are comparable (the tilting rotations of
    # 12-DOF gears, DOFs "<gear>.theta_x" / "<gear>.theta_y", likewise)
    for g in system.gears.values():
        if g.rotation >= 0:
            shapes[g.rotation] *= g.radius_m
        for a in ("theta_x", "theta_y"):
            name = f"{g.name}.{a}"
            if name in system.dof_names:
                shapes[system.dof_names.index(name)] *= g.radius_m
    for c in range(shapes.shape[1]):
        col = shapes[:, c]
        k = int(np.argmax(np.abs(col)))
        shapes[:, c] = col / col[k]
    return ModalResult(w / (2 * math.pi), shapes, system.dof_names, system.mesh_stiffness_N_per_m.copy(),
                       int(np.sum(system.rigid_modes)), system.mesh_names)


def contact_positions(system: LumpedSystem) -> tuple[float, float, float]:
    """(single-contact position, double-contact position, contact ratio estimate) of the first mesh at its
    nominal static force on the flanks the nominal torque loads (the coast side for a negative torque; see module
    docstring)."""
    _, forces, tables = system.loaded_side()
    table = tables[0]
    fs = float(forces[0])
    cnt = contact_count(table, fs)
    pos = np.asarray(table.position, float)
    if cnt is None or not (np.any(cnt == 1) and np.any(cnt >= 2)):
        st = static_stiffness(table, fs)
        kl = st.local_slope_N_per_m
        cnt = np.where(kl > np.mean(kl), 2, 1)
    eps = 1.0 + float(np.mean(cnt >= 2))

    def mid_of_longest(mask):
        n = mask.size
        if mask.all():
            return 0.0
        start = int(np.argmin(mask))  # a False entry: runs do not wrap across it
        best, best_len, i = None, 0, 0
        while i < n:
            j = (start + i) % n
            if mask[j]:
                k = i
                while k < n and mask[(start + k) % n]:
                    k += 1
                if k - i > best_len:
                    best_len, best = k - i, (start + i + (k - i - 1) / 2.0) % n
                i = k
            else:
                i += 1
        return float(pos[0] + best / n) if best is not None else 0.0

    return mid_of_longest(cnt == 1), mid_of_longest(cnt >= 2), eps


@dataclass
class ImpulseResult:
    """Impulse-test frequencies [Hz] (ascending peaks) at the single- and double-contact positions,
    their contact-ratio-weighted mean (when both have the same number of peaks), the positions
    [cycles] and the contact ratio used."""

    single_contact_Hz: np.ndarray
    double_contact_Hz: np.ndarray
    weighted_mean_Hz: np.ndarray
    single_position: float
    double_position: float
    contact_ratio: float

    def to_json(self) -> dict:
        return {"single_contact_Hz": self.single_contact_Hz.tolist(),
                "double_contact_Hz": self.double_contact_Hz.tolist(),
                "weighted_mean_Hz": self.weighted_mean_Hz.tolist(),
                "single_contact_position": self.single_position, "double_contact_position": self.double_position,
                "contact_ratio": self.contact_ratio}


def _free_vibration_peaks(system: LumpedSystem, tau: float, periods: int = 400, rel_peak: float = 0.02):
    sy = system.with_changes(modal_damping_ratio=0.0)
    n, m = sy.n, sy.m
    fext = sy.fext_speed()
    tau_ref = tau - float(sy.phase[0])
    q = static_equilibrium(sy, tau_ref, fext).q
    s = np.concatenate([q, np.zeros(n)])
    xs = max(float(np.max(np.abs(sy.V @ q))), 1e-7)
    f_lo = max(min(sy.natural_frequencies_Hz()), 1.0)
    w_lo = 2 * math.pi * f_lo
    # velocity impulse: x' = 0.01 * xs * omega on the reference gear's rotation, and on the translations
    rg = sy.gears[sy.reference_gear]
    s[n + rg.rotation] += 0.01 * xs * w_lo / rg.radius_m
    trans = [i for g in sy.gears.values() for i in g.translations]
    for i in trans:
        s[n + i] += 0.005 * xs * w_lo
    dt = 1.0 / (32.0 * sy.max_frequency_Hz)
    nsteps = int(periods / f_lo / dt)
    nsteps = min(nsteps, 2_000_000)
    kin = np.array([tau_ref - math.floor(tau_ref), 0.0, 0.0])
    rs = np.zeros((nsteps, 2 * n))
    ro = np.zeros((nsteps, sy.record_width))
    sy.integrate(s, kin, nsteps, dt, fext, rec_every=1, rec_state=rs, rec_out=ro)
    if not np.all(np.isfinite(rs)):
        raise SolverError("impulse test diverged")
    rf = sy.record_fields(ro)
    loaded, x = ((rf["coast_force_N"], rf["coast_approach_m"]) if sy.torque_Nm < 0
                 else (rf["mesh_force_N"], rf["mesh_deflection_m"]))
    if np.any(loaded <= 0):
        raise SolverError("impulse test lost contact: impulse too large for the static load")
    sigs = [x[:, k] - x[:, k].mean() for k in range(m)]
    for i in trans:
        y = rs[:, i]
        sigs.append(y - y.mean())
    win = np.blackman(nsteps)  # side lobes -58 dB: below the peak threshold
    nfft = 1 << int(math.ceil(math.log2(8 * nsteps)))
    spec = np.zeros(nfft // 2 + 1)
    for sg in sigs:
        a = np.abs(np.fft.rfft(sg * win, nfft))
        if a.max() > 0:
            spec += a / a.max()
    freqs = np.fft.rfftfreq(nfft, dt)
    peaks = []
    thr = rel_peak * spec.max()
    for i in range(1, spec.size - 1):
        if spec[i] > thr and spec[i] >= spec[i - 1] and spec[i] > spec[i + 1] and freqs[i] > 0.2 * f_lo:
            y0, y1, y2 = np.log(spec[i - 1:i + 2] + 1e-300)
            d = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
            peaks.append((freqs[i] + d * (freqs[1] - freqs[0]), spec[i]))
    # merge peaks closer than 3 %: keep the strongest
    out = []
    for fpk, amp in sorted(peaks):
        if out and fpk <= out[-1][0] * 1.03:
            if amp > out[-1][1]:
                out[-1] = (fpk, amp)
        else:
            out.append((fpk, amp))
    out = sorted(out, key=lambda t: -t[1])[:n]
    out = [f for f, _ in sorted(out)]
    return np.array(out[:n])


def impulse_test(system: LumpedSystem, positions: tuple[float, float] | None = None) -> ImpulseResult:
    """Impulse test at single- and double-contact positions (see module docstring)."""
    ps, pd, eps = contact_positions(system)
    if positions is not None:
        ps, pd = positions
    fsg = _free_vibration_peaks(system, ps)
    fdb = _free_vibration_peaks(system, pd)
    if fsg.size == fdb.size and fsg.size:
        mean = (2.0 - eps) * fsg + (eps - 1.0) * fdb
    else:
        mean = np.array([])
    return ImpulseResult(fsg, fdb, mean, ps, pd, eps)


def identical_pair_mass_properties(mesh_stiffness_N_per_m: float, f_rigid_Hz: float, f_supported_Hz: float,
                                   support_stiffness_N_per_m: float, base_radius_m: float) -> dict:
    """Mass and polar inertia of two identical gears from two natural frequencies of the lumped model.

    Inverts the 4-DOF spur-pair model (dissertation Eq. 3.1, no damping) for identical gears: with rigid
    supports the mesh mode is ``omega_r**2 = 2 k / M_e`` (``M_e = J / r_b**2``); with translational supports
    ``k_y`` along the line of action the highest mode (``y1 = -y2``, ``r_b theta1 = r_b theta2``) satisfies
    ``det([[k_y + 2k - omega**2 m, 2k], [2k, 2k - omega**2 M_e]]) = 0``, solved for ``m``.  Used to read the
    mass properties implied by published frequencies (docs/validation.md, "The unspecified blank").

    Parameters
    ----------
    mesh_stiffness_N_per_m : float
        Mean mesh stiffness k [N/m] (> 0).
    f_rigid_Hz, f_supported_Hz : float
        Natural frequency with rigid supports and highest natural frequency with supports ``k_y`` [Hz] (> 0).
    support_stiffness_N_per_m : float
        Translational support stiffness k_y of each gear [N/m] (> 0, finite).
    base_radius_m : float
        Base radius r_b [m] (> 0).

    Returns
    -------
    dict
        ``mass_kg``, ``inertia_kgm2``, ``equivalent_mass_kg`` (J/r_b**2) and ``mass_ratio`` (m r_b**2 / J;
        1 for a thin ring at the base circle, about 2 r_b**2/R**2 for a solid disk of radius R).
    """
    vals = {"mesh_stiffness_N_per_m": mesh_stiffness_N_per_m, "f_rigid_Hz": f_rigid_Hz,
            "f_supported_Hz": f_supported_Hz, "support_stiffness_N_per_m": support_stiffness_N_per_m,
            "base_radius_m": base_radius_m}
    for name, v in vals.items():
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ModelError(f"{name} must be a finite number > 0, got {v!r}")
    k, ky, rb = mesh_stiffness_N_per_m, support_stiffness_N_per_m, base_radius_m
    w1, w2 = 2 * math.pi * f_rigid_Hz, 2 * math.pi * f_supported_Hz
    m_e = 2 * k / w1 ** 2
    b = 2 * k - w2 ** 2 * m_e
    if b >= 0:
        raise ModelError(f"f_supported_Hz = {f_supported_Hz:g} Hz must exceed f_rigid_Hz = {f_rigid_Hz:g} Hz for "
                         "identical gears on translational supports (the highest mode lies above the rigid one)")
    m = (ky + 2 * k - 4 * k * k / b) / w2 ** 2
    if m <= 0:
        raise ModelError(f"no positive gear mass gives {f_supported_Hz:g} Hz with k_y = {ky:g} N/m and "
                         f"k = {k:g} N/m: f_supported_Hz [Hz] is too high for these stiffnesses")
    return {"mass_kg": m, "inertia_kgm2": m_e * rb ** 2, "equivalent_mass_kg": m_e, "mass_ratio": m * rb ** 2 / (m_e * rb ** 2)}


@dataclass
class GyroscopicModes:
    """Modes of the linearised system at carrier speed ``carrier_speed_rad_s`` (module docstring).

    ``natural_frequencies_Hz`` (n,) ascending with rigid-body modes as 0; ``types`` (n,) of :data:`MODE_TYPES`;
    ``multiplicity`` (n,); ``mode_shapes`` (n_dof, n) complex, rotations as radius x angle [m], scaled to a largest
    component of 1; ``dof_names``; ``mesh_stiffness_N_per_m`` (m,)."""

    natural_frequencies_Hz: np.ndarray
    types: tuple
    multiplicity: np.ndarray
    mode_shapes: np.ndarray
    dof_names: tuple
    carrier_speed_rad_s: float
    mesh_stiffness_N_per_m: np.ndarray
    mesh_names: tuple = ()
    dominant: tuple = ()

    def to_json(self) -> dict:
        return {
            "carrier_speed_rad_s": self.carrier_speed_rad_s,
            "natural_frequencies_Hz": self.natural_frequencies_Hz.tolist(),
            "modes": [{"frequency_Hz": float(f), "type": t, "multiplicity": int(k),
                       **({} if not self.dominant else dict(zip(("stage", "member", "kinetic_energy_share"),
                                                                 self.dominant[i])))}
                      for i, (f, t, k) in enumerate(zip(self.natural_frequencies_Hz, self.types,
                                                        self.multiplicity))],
            "mode_shapes": {"dof_names": list(self.dof_names),
                            "note": "one row per mode, magnitudes; rotations as radius*theta [m]",
                            "shapes": np.abs(self.mode_shapes).T.tolist()},
            "mesh_stiffness_N_per_m": dict(zip(self.mesh_names, np.atleast_1d(self.mesh_stiffness_N_per_m).tolist())),
            "rigid_body_modes": int(sum(t == "rigid" for t in self.types)),
        }


def _dof_roles(system: LumpedSystem):
    """(central translation DOFs, central rotation DOFs, planet DOFs, per-DOF scale to length units)."""
    planets = {g for c in system.meshes for g, a in c.gear_alias.items() if a != g}
    ct, cr, pl = [], [], []
    scale = np.ones(system.n)
    for g in system.gears.values():
        if g.rotation >= 0:
            scale[g.rotation] = g.radius_m
        if g.name in planets:
            pl += list(g.translations) + ([g.rotation] if g.rotation >= 0 else [])
        else:
            ct += list(g.translations)
            if g.rotation >= 0:
                cr.append(g.rotation)
    return np.array(ct, int), np.array(cr, int), np.array(pl, int), scale


def _classify(shape: np.ndarray, ct, cr, tol: float) -> str:
    a = np.abs(shape)
    top = float(a.max()) if a.size else 0.0
    if top == 0.0:
        return "mixed"
    t = float(a[ct].max()) / top if ct.size else 0.0
    r = float(a[cr].max()) / top if cr.size else 0.0
    if t < tol and r < tol:
        return "planet"
    if t < tol:
        return "rotational"
    if r < tol:
        return "translational"
    return "mixed"


def gyroscopic_modes(system: LumpedSystem, carrier_speed_rad_s: float = 0.0, *, type_tol: float = 1e-5,
                     multiplicity_rtol: float = 1e-6) -> GyroscopicModes:
    """Modes of the undamped linearisation of ``system`` at carrier speed ``carrier_speed_rad_s`` [rad/s] (the
    quadratic eigenproblem of the module docstring; at 0 the symmetric one), classified.

    ``type_tol``: largest relative motion of the central members' translations / rotations counted as none;
    ``multiplicity_rtol``: relative distance of equal frequencies.
    """
    wc = float(carrier_speed_rad_s)
    if not math.isfinite(wc):
        raise ModelError(f"carrier speed [rad/s] must be finite, got {carrier_speed_rad_s!r}")
    n = system.n
    keff = system.k_lin - wc * wc * system.K_W
    n_rigid = int(np.sum(system.rigid_modes))
    if wc == 0.0 or not np.any(system.G):
        # symmetric: K phi = w^2 M phi through the Cholesky factor M = L L^T
        li = np.linalg.inv(np.linalg.cholesky(system.M))
        a = li @ keff @ li.T
        w2, psi = np.linalg.eigh(0.5 * (a + a.T))
        omega = np.sqrt(np.clip(w2, 0.0, None))
        shapes = (li.T @ psi).astype(complex)
    else:
        minv = system.minv
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -minv @ keff
        a[n:, n:] = -wc * (minv @ system.G)
        lam, vec = np.linalg.eig(a)
        order = np.argsort(np.abs(lam))
        lam, vec = lam[order], vec[:, order]
        # the 2 r roots nearest 0 are the rigid-body modes; of the others keep the roots with Im > 0
        rig = list(range(2 * n_rigid))
        rest = [i for i in range(2 * n) if i not in rig and lam[i].imag > 0]
        idx = rig[::2] + rest
        if len(idx) != n:
            raise SolverError(f"{system.name}: the gyroscopic eigenproblem at {wc:g} rad/s gave {len(rest)} "
                              f"oscillating roots for {n - n_rigid} elastic modes (unstable at this speed?)")
        omega = np.array([0.0] * n_rigid + [abs(lam[i].imag) for i in rest])
        shapes = vec[:n, idx]
    order = np.argsort(omega)
    omega, shapes = omega[order], shapes[:, order]
    if n_rigid:
        omega[:n_rigid] = 0.0
    dominant = dominant_members(system, shapes)
    ct, cr, _, scale = _dof_roles(system)
    shapes = shapes * scale[:, None]
    for c in range(n):
        k = int(np.argmax(np.abs(shapes[:, c])))
        if shapes[k, c] != 0:
            shapes[:, c] /= shapes[k, c]
    types = []
    for c in range(n):
        types.append("rigid" if c < n_rigid else _classify(shapes[:, c], ct, cr, type_tol))
    f = omega / (2 * math.pi)
    mult = np.ones(n, int)
    top = max(float(f.max()), 1.0)
    for i in range(n):
        same = [j for j in range(n) if types[j] == types[i] and abs(f[j] - f[i]) <= multiplicity_rtol * top]
        mult[i] = len(same)
    return GyroscopicModes(f, tuple(types), mult, shapes, system.dof_names, wc, system.mesh_stiffness_N_per_m.copy(),
                           system.mesh_names, dominant)


def dominant_members(system: LumpedSystem, shapes: np.ndarray) -> tuple[tuple[str, str, float], ...]:
    """Per mode (columns of ``shapes`` (n, k), real or complex, in the system's coordinates): the body with the
    largest share of the mode's kinetic energy ``|phi_i|^2 M_ii`` over its DOFs, as (its stage ('' outside a
    gearbox), its name, its share in [0, 1])."""
    owner = [name.rsplit(".", 1)[0] for name in system.dof_names]
    bodies = sorted(set(owner), key=owner.index)
    pick = np.array([[o == b for o in owner] for b in bodies], float)      # (bodies, n)
    e = (np.abs(np.asarray(shapes)) ** 2) * np.diag(system.M)[:, None]     # (n, k)
    share = pick @ e
    total = share.sum(axis=0)
    out = []
    for c in range(share.shape[1]):
        i = int(np.argmax(share[:, c]))
        out.append((system.gears[bodies[i]].stage, bodies[i],
                    float(share[i, c] / total[c]) if total[c] > 0 else 0.0))
    return tuple(out)

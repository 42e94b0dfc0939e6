"""Spur-pair lumped model (dissertation Eqs. 3.1-3.4) and its simulator object.

Coordinates ``q = [y1, th1, y2, th2]`` (a translation is dropped when its support is rigid,
``k_y = inf``): ``y_i`` translations along the line of action [m], ``th1`` rotation of gear 1 in its
direction of rotation, ``th2`` rotation of gear 2 *against* its direction of rotation [rad], both
measured from the reference rotation.  Mesh deflection (Eq. 3.4)

    x = v^T q,  v = [1, r_b1, -1, r_b2]

Equations of motion (Eq. 3.1)

    M q'' + C q' + K q + F(tau, x) v = f_ext

with ``M = diag(m1, I1, m2, I2)``, ``K = diag(k_y1, k_th1, k_y2, k_th2)`` (support stiffnesses;
``k_th = 0`` is a free rotation), ``C`` the modal damping matrix (below) and
``f_ext = F_s [0, r_b1, 0, r_b2]`` (Eq. 3.3c, ``F_s = T_1 / r_b1``) in the constant-speed experiment,
or ``f_ext = [0, T_1, 0, -T_2]`` with shaft torques ``T_1``, ``T_2`` (each positive in its gear's
direction of rotation; a braking load on gear 2 is negative) in drivetrain coupling.

Mesh position: ``tau = z1 phi1 / (2 pi) + tau_0`` with ``phi1`` gear 1's actual rotation angle
(reference + ``th1``); ``tau_0`` = ``mesh_phase``.

Damping policy: modal damping with one ratio ``zeta`` for every elastic mode of the system
linearised at the nominal torque (mesh stiffness = cycle mean of the force law's stiffness: the
local slope of the FDF at the static deflection for ``hac``).  ``C = M Phi diag(2 zeta omega_r)
Phi^T M`` with mass-normalised modes ``Phi``; rigid-body rotation modes (omega = 0) get no damping,
so the mean speed is kept.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hacgear_core.dynamics import kernels
from hacgear_core.dynamics.conventional import ForceLaw, make_force_law
from hacgear_core.dynamics.fdf import TableArrays, table_arrays
from hacgear_core.errors import ModelError, SolverError

__all__ = [
    "SpurPairParameters",
    "SpurPairSystem",
    "SpurPairSimulator",
    "StepResult",
    "from_model",
]

_DOF_NAMES = ("y1", "th1", "y2", "th2")


def _pair(name, value, unit, lo, hi, *, lo_open=True, allow_inf=False, integer=False):
    try:
        a, b = value
    except (TypeError, ValueError):
        raise ModelError(f"{name} [{unit}] must be a pair (gear 1, gear 2), got {value!r}") from None
    out = []
    for v in (a, b):
        if integer:
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise ModelError(f"{name} [{unit}] must be integers in [{lo}, {hi}], got {value!r}")
            out.append(int(v))
            continue
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise ModelError(f"{name} [{unit}] must be numbers, got {value!r}") from None
        if math.isnan(v) or (math.isinf(v) and not allow_inf):
            raise ModelError(f"{name} [{unit}] must be finite{' or inf' if allow_inf else ''}, got {value!r}")
        bad_lo = v <= lo if lo_open else v < lo
        if bad_lo or (not math.isinf(v) and v > hi):
            br = "(" if lo_open else "["
            raise ModelError(f"{name} [{unit}] must be in {br}{lo:g}, {hi:g}]"
                             f"{' or inf' if allow_inf else ''}, got {value!r}")
        out.append(v)
    return tuple(out)


@dataclass(frozen=True)
class SpurPairParameters:
    """Lumped parameters of a spur pair (SI).  Pairs are (gear 1 = driver, gear 2 = driven).

    Attributes
    ----------
    mass_kg : (float, float)
        Gear masses [kg] (used only for translations with finite ``bearing_stiffness_N_per_m``).
    inertia_kg_m2 : (float, float)
        Polar moments of inertia [kg m^2].
    base_radius_m : (float, float)
        Base radii of the loaded flanks [m].
    teeth : (int, int)
    bearing_stiffness_N_per_m : (float, float)
        Translational support stiffness along the line of action [N/m]; ``inf`` = rigid.
    rotational_stiffness_Nm_per_rad : (float, float)
        Rotational support stiffness to the reference rotation [N m/rad]; 0 = free rotation.
    modal_damping_ratio : float
        Ratio of critical damping of every elastic mode, in [0, 1).
    torque_Nm : float
        Nominal torque on gear 1 [N m] (> 0): sets ``F_s`` and the linearisation for damping.
    mesh_phase : float
        Mesh position [cycles] at zero rotation of gear 1.
    """

    mass_kg: tuple[float, float]
    inertia_kg_m2: tuple[float, float]
    base_radius_m: tuple[float, float]
    teeth: tuple[int, int]
    bearing_stiffness_N_per_m: tuple[float, float] = (math.inf, math.inf)
    rotational_stiffness_Nm_per_rad: tuple[float, float] = (0.0, 0.0)
    modal_damping_ratio: float = 0.02
    torque_Nm: float = 300.0
    mesh_phase: float = 0.0

    def __post_init__(self) -> None:
        s = object.__setattr__
        s(self, "mass_kg", _pair("mass_kg", self.mass_kg, "kg", 0.0, 1e6))
        s(self, "inertia_kg_m2", _pair("inertia_kg_m2", self.inertia_kg_m2, "kg*m^2", 0.0, 1e6))
        s(self, "base_radius_m", _pair("base_radius_m", self.base_radius_m, "m", 0.0, 20.0))
        s(self, "teeth", _pair("teeth", self.teeth, "-", 6, 1000, integer=True))
        s(self, "bearing_stiffness_N_per_m",
          _pair("bearing_stiffness_N_per_m", self.bearing_stiffness_N_per_m, "N/m", 0.0, 1e15, allow_inf=True))
        s(self, "rotational_stiffness_Nm_per_rad",
          _pair("rotational_stiffness_Nm_per_rad", self.rotational_stiffness_Nm_per_rad, "N*m/rad", 0.0, 1e12,
                lo_open=False))
        for name, lo, hi, unit in (("modal_damping_ratio", 0.0, 1.0, "-"), ("torque_Nm", 0.0, 1e7, "N*m")):
            v = getattr(self, name)
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise ModelError(f"{name} [{unit}] must be a number, got {v!r}") from None
            ok = (0.0 <= v < 1.0) if name == "modal_damping_ratio" else (0.0 < v <= hi)
            if not ok or math.isnan(v):
                rng = "[0, 1)" if name == "modal_damping_ratio" else f"(0, {hi:g}]"
                raise ModelError(f"{name} [{unit}] must be in {rng}, got {getattr(self, name)!r}")
            s(self, name, v)
        ph = float(self.mesh_phase)
        if not math.isfinite(ph):
            raise ModelError(f"mesh_phase [cycles] must be finite, got {self.mesh_phase!r}")
        s(self, "mesh_phase", ph)

    @property
    def static_force_N(self) -> float:
        """Nominal static mesh force F_s = T_1 / r_b1 [N]."""
        return self.torque_Nm / self.base_radius_m[0]

    @property
    def rigid_supports(self) -> bool:
        return all(math.isinf(k) for k in self.bearing_stiffness_N_per_m)

    def replace(self, **changes) -> "SpurPairParameters":
        from dataclasses import replace

        return replace(self, **changes)


def _eigh_diagonal_mass(k: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenpairs of K φ = ω² M φ for symmetric K (n, n) and a diagonal mass matrix given by its positive
    diagonal ``m`` (n,): ascending ω² and mass-normalised shapes (φᵀ M φ = I), through the symmetric standard
    problem of M^-1/2 K M^-1/2 (numpy only: the FMUs load faster without scipy.linalg)."""
    s = 1.0 / np.sqrt(m)
    w2, psi = np.linalg.eigh(s[:, None] * k * s[None, :])
    return w2, s[:, None] * psi


class SpurPairSystem:
    """Assembled spur-pair model: active DOFs, matrices, damping, force law and table arrays.

    Parameters
    ----------
    params : SpurPairParameters
    table : mesh table (tables contract)
    force_law : str
        One of ``hac``, ``ste``, ``average_slope``, ``local_slope`` (see
        :mod:`~hacgear_core.dynamics.conventional`).
    """

    def __init__(self, params: SpurPairParameters, table, force_law: str = "hac") -> None:
        self.params = params
        self.table = table
        ta = table_arrays(table)
        self.ta: TableArrays = ta
        tz = tuple(int(z) for z in getattr(table, "teeth", params.teeth))
        if tz != params.teeth:
            raise ModelError(f"teeth {params.teeth} do not match the table's teeth {tz}")
        rb_t = tuple(float(r) for r in getattr(table, "base_radius_m", params.base_radius_m))
        if not np.allclose(rb_t, params.base_radius_m, rtol=1e-3):
            raise ModelError(f"base_radius_m {params.base_radius_m} m does not match the table's {rb_t} m")
        self.law: ForceLaw = make_force_law(table, force_law, params.static_force_N)
        p = params
        rb1, rb2 = p.base_radius_m
        full_m = np.array([p.mass_kg[0], p.inertia_kg_m2[0], p.mass_kg[1], p.inertia_kg_m2[1]])
        full_k = np.array([p.bearing_stiffness_N_per_m[0], p.rotational_stiffness_Nm_per_rad[0],
                           p.bearing_stiffness_N_per_m[1], p.rotational_stiffness_Nm_per_rad[1]])
        full_v = np.array([1.0, rb1, -1.0, rb2])
        full_u = np.array([0.0, rb1, 0.0, rb2])
        active = [i for i in range(4) if not math.isinf(full_k[i])]
        self.active = tuple(active)
        self.dof_names = tuple(_DOF_NAMES[i] for i in active)
        self.n = len(active)
        self.ith1 = self.dof_names.index("th1")
        self.ith2 = self.dof_names.index("th2")
        self.m = full_m[active].copy()
        self.minv = 1.0 / self.m
        self.kd = full_k[active].copy()
        self.v = full_v[active].copy()
        self.u = full_u[active].copy()
        self.ratio = rb1 / rb2
        self.z1_2pi = p.teeth[0] / (2 * math.pi)
        self.rb = (rb1, rb2)
        # linearisation and modal damping
        km = self.law.mean_stiffness_N_per_m
        self.k_lin = np.diag(self.kd) + km * np.outer(self.v, self.v)
        w2, phi = _eigh_diagonal_mass(self.k_lin, self.m)
        w2 = np.clip(w2, 0.0, None)
        omega = np.sqrt(w2)
        rigid = omega < 1e-6 * max(omega.max(), 1.0)
        self.modal_omega = omega
        self.modal_shapes = phi
        self.rigid_modes = rigid
        zeta = p.modal_damping_ratio
        d = np.where(rigid, 0.0, 2.0 * zeta * omega)
        mm = np.diag(self.m)
        self.cm = np.ascontiguousarray(mm @ phi @ np.diag(d) @ phi.T @ mm)
        # highest frequency the integrator must resolve: linearisation at the stiffest table slope
        kmax = max(km, float(np.max(np.diff(ta.ftab, axis=1))) * ta.inv_dx,
                   float(np.max(self.law.lin[0])) if self.law.law == kernels.LAW_LINEAR else 0.0)
        w2max, _ = _eigh_diagonal_mass(np.diag(self.kd) + kmax * np.outer(self.v, self.v), self.m)
        self.max_frequency_Hz = float(np.sqrt(max(w2max.max(), 0.0)) / (2 * math.pi))
        self.work = np.zeros((5, 2 * self.n))
        #: compiled loop for this force law and DOF count (kernels.select_kernel)
        self.kernel = kernels.select_kernel(self.law.law, self.n)

    # ------------------------------------------------------------------ force law in Python
    def force(self, tau, x) -> np.ndarray:
        """Mesh force [N] of the system's force law at mesh positions ``tau`` [cycles] and
        deflections ``x`` [m] (broadcast arrays)."""
        tau, x = np.broadcast_arrays(np.asarray(tau, float), np.asarray(x, float))
        tf, xf = np.ascontiguousarray(tau.ravel()), np.ascontiguousarray(x.ravel())
        out = np.empty(tf.size)
        if self.law.law == kernels.LAW_TABLE:
            kernels.table_force_many(self.ta.ftab, self.ta.x0, self.ta.inv_dx, tf, xf, out)
        else:
            lin = self.law.lin
            npos = lin.shape[1]
            t = (tf - np.floor(tf)) * npos
            i = np.minimum(t.astype(int), npos - 1)
            a = t - i
            i1 = (i + 1) % npos
            k, e, f0 = (lin[r, i] + a * (lin[r, i1] - lin[r, i]) for r in range(3))
            out = np.maximum(k * (xf - e) + f0, 0.0)
        return out.reshape(tau.shape)

    def fext_speed(self, torque_Nm: float | None = None) -> np.ndarray:
        """External generalized forces of the constant-speed experiment, F_s u (Eq. 3.3c)."""
        fs = (self.params.torque_Nm if torque_Nm is None else torque_Nm) / self.rb[0]
        return np.ascontiguousarray(fs * self.u)

    def fext_torque(self, t1_Nm: float, t2_Nm: float) -> np.ndarray:
        """External generalized forces for shaft torques T1, T2 [N m] (positive in each gear's
        direction of rotation)."""
        f = np.zeros(self.n)
        f[self.ith1] = t1_Nm
        f[self.ith2] = -t2_Nm
        return f

    def static_state(self, tau: float = 0.0, torque_Nm: float | None = None) -> np.ndarray:
        """Static equilibrium state (2n,) at mesh position ``tau`` under the speed-mode load
        (zero velocities).  With a free rotation the mesh carries exactly F_s."""
        fext = self.fext_speed(torque_Nm)
        kd, v = self.kd, self.v
        free = kd == 0
        q = np.zeros(self.n)

        def x_of_force(f):
            xx = 0.0
            for i in range(self.n):
                if kd[i] > 0:
                    xx += v[i] * (fext[i] - f * v[i]) / kd[i]
            return xx

        if np.any(free):
            fs = float(np.max(fext[free] / v[free]))
            xs = self._deflection_at(tau, fs)
            for i in range(self.n):
                if kd[i] > 0:
                    q[i] = (fext[i] - fs * v[i]) / kd[i]
            rest = xs - float(v @ q)
            i_free = self.ith2 if free[self.ith2] else self.ith1
            q[i_free] = rest / v[i_free]
        else:  # all supported: solve x = x_of_force(F(tau, x)) by bisection
            lo, hi = self.ta.x0 - 1e-3, x_of_force(0.0)
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                if mid - x_of_force(float(self.force(tau, mid))) > 0:
                    hi = mid
                else:
                    lo = mid
            f = float(self.force(tau, 0.5 * (lo + hi)))
            for i in range(self.n):
                q[i] = (fext[i] - f * v[i]) / kd[i]
        return np.concatenate([q, np.zeros(self.n)])

    def _deflection_at(self, tau: float, force_N: float) -> float:
        """Deflection x with F(tau, x) = force_N (bisection on the force law)."""
        lo = self.ta.x0 - 1e-3
        hi = self.ta.x0 + self.ta.dx * (self.ta.ftab.shape[1] - 1)
        while float(self.force(tau, hi)) < force_N:
            hi = hi + (hi - lo)
            if hi > 1.0:
                raise SolverError(f"mesh force {force_N:g} N not reached by the force law below 1 m deflection")
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if float(self.force(tau, mid)) < force_N:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    def cached(self, what: str, force_N: float):
        """Per-system cache of static quantities used at every speed of a sweep:
        ``deflection_at_0`` (static deflection at mesh position 0 [m]) and ``static_strain_max``
        ({gauge: max static root strain})."""
        key = (what, float(force_N))
        c = self.__dict__.setdefault("_cache", {})
        if key not in c:
            if what == "deflection_at_0":
                c[key] = self._deflection_at(0.0, force_N)
            elif what == "static_strain_max":
                from hacgear_core.post import static_strain_max

                c[key] = static_strain_max(self.table, force_N)
            else:
                raise KeyError(what)
        return c[key]

    def natural_frequencies_Hz(self) -> np.ndarray:
        """Elastic natural frequencies of the linearisation used for damping [Hz], ascending."""
        return np.sort(self.modal_omega[~self.rigid_modes]) / (2 * math.pi)

    def steps_per_cycle(self, mesh_frequency_Hz: float, minimum: int = 128, per_period: int = 32) -> int:
        """Power-of-two steps per mesh cycle >= ``minimum`` such that the step also resolves the
        highest natural frequency with >= ``per_period`` steps."""
        need = max(minimum, per_period * self.max_frequency_Hz / mesh_frequency_Hz)
        return int(2 ** math.ceil(math.log2(need)))

    def integrate(self, s, kin, n_steps, h, fext, *, mode=kernels.MODE_SPEED, rec_every=0,
                  rec_state=None, rec_out=None) -> int:
        """Call the compiled kernel (see :func:`~hacgear_core.dynamics.kernels.integrate`)."""
        if rec_state is None:
            rec_state = np.zeros((0, 2 * self.n))
            rec_out = np.zeros((0, 5))
        return self.kernel(
            s, kin, int(n_steps), float(h), mode, self.z1_2pi, self.ith1, self.ith2, self.ratio, self.minv,
            self.kd, self.cm, self.v, fext, self.ta.ftab, self.ta.x0, self.ta.inv_dx,
            self.law.lin, self.work, int(rec_every), rec_state, rec_out,
        )


@dataclass(frozen=True)
class StepResult:
    """Outcome of :meth:`SpurPairSimulator.advance`."""

    success: bool
    message: str
    n_substeps: int


class SpurPairSimulator:
    """Time-stepping simulator of one spur pair (library and FMU slaves use this object).

    Two operating modes:

    * ``"speed"`` (constant-speed experiment): :meth:`set_speed_input` sets gear 1's reference speed,
      :meth:`set_torque_set_point` the torque; the deviations are integrated around the reference.
    * ``"torque"`` (drivetrain coupling): :meth:`set_torque_inputs` sets the shaft torques; absolute
      angles and speeds follow from the dynamics (needs zero rotational supports).

    Parameters
    ----------
    params : SpurPairParameters
    table : mesh table (tables contract)
    internal_step_s : float, optional
        Largest internal RK4 step [s]; default: mesh period / 128 at the current speed and
        1/32 of the period of the highest natural frequency.
    force_law : str
        ``hac`` (default) or a conventional law.
    """

    def __init__(self, params: SpurPairParameters, table, internal_step_s: float | None = None,
                 force_law: str = "hac") -> None:
        if internal_step_s is not None and not (math.isfinite(internal_step_s) and internal_step_s > 0):
            raise ModelError(f"internal_step_s [s] must be > 0 and finite, got {internal_step_s!r}")
        self.system = SpurPairSystem(params, table, force_law)
        self.params = params
        self.internal_step_s = internal_step_s
        n = self.system.n
        self.s = np.zeros(2 * n)
        self.kin = np.zeros(3)
        self._rec_s = np.zeros((1, 2 * n))
        self._rec_o = np.zeros((1, 5))
        sy = self.system
        self._v = [float(c) for c in sy.v]
        self._rb = (float(sy.rb[0]), float(sy.rb[1]))
        # per support (y1, y2): (state index, stiffness) of a translational DOF, or (-1, 0) when rigid (its
        # reaction then balances the mesh force: -F on gear 1, +F on gear 2)
        self._supports = tuple(
            (sy.dof_names.index(nm), float(sy.kd[sy.dof_names.index(nm)])) if nm in sy.dof_names else (-1, 0.0)
            for nm in ("y1", "y2"))
        self.reset()

    # ------------------------------------------------------------------ inputs
    def reset(self, speed_rad_s: float = 0.0) -> None:
        """Static equilibrium at the nominal torque, mesh position ``mesh_phase``, speed mode."""
        sy = self.system
        self.mode = "speed"
        self.torque_Nm = self.params.torque_Nm
        self.t1_Nm = self.params.torque_Nm
        self.t2_Nm = -self.params.torque_Nm * sy.rb[1] / sy.rb[0]
        self.fext = sy.fext_speed(self.torque_Nm)
        ph = self.params.mesh_phase
        self.kin[:] = (ph - math.floor(ph), math.floor(ph), float(speed_rad_s))
        self.s[:] = sy.static_state(ph, self.torque_Nm)
        self.time_s = 0.0
        self._update_outputs()

    def set_speed_input(self, speed_rad_s: float | None = None, mesh_frequency_Hz: float | None = None) -> None:
        """Constant-speed experiment: gear 1 reference speed [rad/s] or mesh frequency [Hz]."""
        if (speed_rad_s is None) == (mesh_frequency_Hz is None):
            raise ModelError("give exactly one of speed_rad_s [rad/s] or mesh_frequency_Hz [Hz]")
        if mesh_frequency_Hz is not None:
            speed_rad_s = float(mesh_frequency_Hz) / self.system.z1_2pi
        speed_rad_s = float(speed_rad_s)
        if not math.isfinite(speed_rad_s):
            raise ModelError(f"speed [rad/s] must be finite, got {speed_rad_s!r}")
        if self.mode != "speed":
            self.mode = "speed"
            self.fext = self.system.fext_speed(self.torque_Nm)
        self.kin[2] = speed_rad_s

    def set_torque_set_point(self, torque_Nm: float) -> None:
        """Constant-speed experiment: torque on gear 1 [N m] (> 0; gear 2 carries T r_b2/r_b1)."""
        torque_Nm = float(torque_Nm)
        if not (math.isfinite(torque_Nm) and torque_Nm >= 0):
            raise ModelError(f"torque [N*m] must be finite and >= 0, got {torque_Nm!r}")
        self.torque_Nm = torque_Nm
        if self.mode == "speed":
            self.fext = self.system.fext_speed(torque_Nm)

    def set_torque_inputs(self, t1_Nm: float, t2_Nm: float) -> None:
        """Drivetrain coupling: shaft torques [N m] on gear 1 and gear 2, each positive in that
        gear's direction of rotation (a load on gear 2 is negative).  Switches to torque mode."""
        t1, t2 = float(t1_Nm), float(t2_Nm)
        if not (math.isfinite(t1) and math.isfinite(t2)):
            raise ModelError(f"shaft torques [N*m] must be finite, got ({t1_Nm!r}, {t2_Nm!r})")
        if any(k != 0 for k in self.params.rotational_stiffness_Nm_per_rad):
            raise ModelError("torque inputs need rotational_stiffness_Nm_per_rad = (0, 0): in drivetrain "
                             "coupling the shaft compliance belongs to the drivetrain model")
        if self.mode != "torque":
            self.mode = "torque"
            # move any rigid-body deviation into the reference: th1 -> 0
            sy, n = self.system, self.system.n
            a, b = self.s[sy.ith1], self.s[n + sy.ith1]
            self.s[sy.ith1] = 0.0
            self.s[n + sy.ith1] = 0.0
            self.s[sy.ith2] += sy.ratio * a
            self.s[n + sy.ith2] += sy.ratio * b
            self.kin[0] += sy.z1_2pi * a
            self.kin[2] += b
            while self.kin[0] >= 1.0:
                self.kin[0] -= 1.0
                self.kin[1] += 1.0
            while self.kin[0] < 0.0:
                self.kin[0] += 1.0
                self.kin[1] -= 1.0
        self.t1_Nm, self.t2_Nm = t1, t2
        self.fext = self.system.fext_torque(t1, t2)

    # ------------------------------------------------------------------ stepping
    @property
    def current_internal_step_s(self) -> float:
        """The largest RK4 sub-step [s] :meth:`advance` would use now (depends on the speed)."""
        return self._internal_step()

    def _internal_step(self) -> float:
        sy = self.system
        h = 1.0 / (32.0 * sy.max_frequency_Hz)
        fm = abs(self.kin[2]) * sy.z1_2pi + abs(self.s[sy.n + sy.ith1]) * sy.z1_2pi
        if fm > 0:
            h = min(h, 1.0 / (128.0 * fm))
        if self.internal_step_s is not None:
            h = min(h, self.internal_step_s)
        return h

    def advance(self, dt: float) -> StepResult:
        """Advance by ``dt`` [s] (any size > 0) with equal RK4 sub-steps <= the internal step.
        On failure (non-finite state) the state is left unchanged and ``success`` is False.

        One call of the compiled kernel, which also records the mesh outputs (mesh position, deflection,
        force, DTE) at the end of the step; the other output attributes follow from the state in plain
        Python floats.  This is the per-step path of the FMUs too (a communication step costs a few µs
        beyond the kernel's own work)."""
        try:
            dt = float(dt)
        except (TypeError, ValueError):
            return StepResult(False, f"step size dt [s] must be a number, got {dt!r}", 0)
        if not (math.isfinite(dt) and dt > 0):
            return StepResult(False, f"step size dt [s] must be finite and > 0, got {dt!r}", 0)
        nsub = max(1, int(math.ceil(dt / self._internal_step() - 1e-9)))
        s, kin = self.s, self.kin
        s0, k0 = s.copy(), kin.copy()
        self.system.integrate(s, kin, nsub, dt / nsub, self.fext,
                              mode=kernels.MODE_SPEED if self.mode == "speed" else kernels.MODE_TORQUE,
                              rec_every=nsub, rec_state=self._rec_s, rec_out=self._rec_o)
        st, kt = s.tolist(), kin.tolist()
        isf = math.isfinite
        if not (all(map(isf, st)) and all(map(isf, kt))):
            s[:], kin[:] = s0, k0
            return StepResult(False, f"integration diverged within dt = {dt:g} s (state not finite); "
                                     f"state restored", nsub)
        self.time_s += dt
        pos, x, f, dte, _ = self._rec_o[0].tolist()
        self._set_outputs(st, kt, pos, x, f, dte)
        return StepResult(True, "", nsub)

    def run(self, duration_s: float, record_dt_s: float) -> dict:
        """Integrate ``duration_s`` [s] recording every ``record_dt_s`` [s]; returns arrays
        ``time_s``, ``mesh_position``, ``mesh_deflection_m``, ``mesh_force_N``,
        ``dynamic_transmission_error_m``, ``state`` (nr, 2n)."""
        nrec = int(round(duration_s / record_dt_s))
        if nrec < 1:
            raise ModelError("duration_s must be >= record_dt_s > 0")
        h0 = self._internal_step()
        per = max(1, int(math.ceil(record_dt_s / h0 - 1e-9)))
        h = record_dt_s / per
        rs, ro = np.zeros((nrec, 2 * self.system.n)), np.zeros((nrec, 5))
        mode = kernels.MODE_SPEED if self.mode == "speed" else kernels.MODE_TORQUE
        t0 = self.time_s
        self.system.integrate(self.s, self.kin, nrec * per, h, self.fext, mode=mode, rec_every=per,
                              rec_state=rs, rec_out=ro)
        if not np.all(np.isfinite(rs)):
            raise SolverError("integration diverged (state not finite)")
        self.time_s = t0 + nrec * record_dt_s
        self._update_outputs()
        return {"time_s": t0 + ro[:, 4], "mesh_position": ro[:, 0], "mesh_deflection_m": ro[:, 1],
                "mesh_force_N": ro[:, 2], "dynamic_transmission_error_m": ro[:, 3], "state": rs}

    # ------------------------------------------------------------------ state snapshots (FMI get/set state)
    def get_state(self) -> dict:
        """A snapshot of everything :meth:`advance` depends on (copying arrays)."""
        return {"s": self.s.copy(), "kin": self.kin.copy(), "time_s": self.time_s, "mode": self.mode,
                "fext": self.fext.copy(), "torque_Nm": self.torque_Nm, "t1_Nm": self.t1_Nm, "t2_Nm": self.t2_Nm}

    def set_state(self, snap: dict) -> None:
        """Restore a snapshot from :meth:`get_state` (in place; outputs updated)."""
        if snap["s"].shape != self.s.shape:
            raise ModelError(f"state snapshot has {snap['s'].size} entries, this simulator {self.s.size}")
        self.s[:] = snap["s"]
        self.kin[:] = snap["kin"]
        self.fext = snap["fext"].copy()
        self.time_s, self.mode = snap["time_s"], snap["mode"]
        self.torque_Nm, self.t1_Nm, self.t2_Nm = snap["torque_Nm"], snap["t1_Nm"], snap["t2_Nm"]
        self._update_outputs()

    # ------------------------------------------------------------------ outputs
    def _update_outputs(self) -> None:
        """Output attributes from the state, with the force law evaluated in Python (after reset,
        set_state, run)."""
        sy = self.system
        st, kt = self.s.tolist(), self.kin.tolist()
        x = sum(vi * si for vi, si in zip(self._v, st))
        tau = kt[0] + sy.z1_2pi * st[sy.ith1]
        self._set_outputs(st, kt, kt[1] + tau, x, float(sy.force(tau, x)),
                          self._rb[0] * st[sy.ith1] + self._rb[1] * st[sy.ith2])

    def _set_outputs(self, st: list, kt: list, pos: float, x: float, f: float, dte: float) -> None:
        """Set the output attributes from the state ``st`` (2n floats), kinematics ``kt`` (3 floats) and the
        mesh outputs: unwrapped mesh position [-], mesh deflection [m], mesh force [N], DTE [m]."""
        sy, n = self.system, self.system.n
        i1, i2 = sy.ith1, sy.ith2
        self.mesh_deflection_m = x
        self.mesh_position = pos
        self.mesh_force_N = f
        self.in_contact = f > 0.0
        self.dynamic_transmission_error_m = dte
        phi_ref = (kt[1] + kt[0] - self.params.mesh_phase) / sy.z1_2pi
        ratio = sy.ratio
        self.angle1_rad = phi_ref + st[i1]
        self.angle2_rad = ratio * phi_ref - st[i2]
        self.speed1_rad_s = kt[2] + st[n + i1]
        self.speed2_rad_s = ratio * kt[2] - st[n + i2]
        (i_y1, k1), (i_y2, k2) = self._supports
        self.bearing_force_N = (k1 * st[i_y1] if i_y1 >= 0 else -f, k2 * st[i_y2] if i_y2 >= 0 else f)
        self.translation_m = (st[i_y1] if i_y1 >= 0 else 0.0, st[i_y2] if i_y2 >= 0 else 0.0)

    def strain(self, gauge: str) -> float:
        """Root strain [-] now at ``gauge`` ("<gear>/<gauge>") on one physical tooth of that gear:
        the tooth of the reference pair at mesh position 0, back in mesh every z mesh cycles
        (pair phase ``((tau + z/2) mod z) - z/2``, see :func:`hacgear_core.post.pair_interpolate`)."""
        from hacgear_core.post import pair_interpolate

        tab = self.system.table
        strain = getattr(tab, "strain", None) or {}
        if gauge not in strain:
            raise ModelError(f"no strain gauge {gauge!r} in the table; gauges: {sorted(strain)}")
        gear = gauge.split("/", 1)[0]
        names = tuple(getattr(tab, "gear_names", ()))
        z = self.params.teeth[names.index(gear)] if gear in names else self.params.teeth[1]
        phase = ((self.mesh_position + 0.5 * z) % z) - 0.5 * z
        return float(pair_interpolate(tab, strain[gauge], [phase], [self.mesh_deflection_m])[0])

    @property
    def peak_pressure_Pa(self) -> float:
        """Maximum contact pressure over all teeth now [Pa] (table post-processing)."""
        from hacgear_core.post import interpolate_table

        return float(interpolate_table(self.system.table, self.system.table.peak_pressure_Pa,
                                       [self.mesh_position], [self.mesh_deflection_m])[0])


def from_model(model, mesh_name: str | None = None, table=None) -> SpurPairParameters:
    """Map a :class:`hacgear_core.model.Model` (kind ``spur_pair``) to :class:`SpurPairParameters`.

    Masses/inertias: those of :func:`hacgear_core.geometry.gear_geometry` (the gear's ``mass_kg`` /
    ``inertia_kgm2`` when given, else the generated blank with its teeth, as ``hacgear info`` reports).  Base radii and teeth come from
    ``table`` when given (they define the FDF's deflection), else from module, teeth and the loaded
    flank's pressure angle.  Torque: ``[operating] torque_Nm`` referred to gear 1.
    """
    from hacgear_core.geometry import gear_geometry

    if getattr(model, "kind", "spur_pair") not in ("spur_pair",):
        raise ModelError(f"from_model: model kind must be 'spur_pair', got {model.kind!r}")
    mesh = model.mesh(mesh_name)
    ga, gb = model.gear(mesh.gear_a), model.gear(mesh.gear_b)
    masses, inertias, rbs, kys, kts = [], [], [], [], []
    for g, flank in ((ga, mesh.flank_a), (gb, mesh.flank_b)):
        gg = gear_geometry(g)
        masses.append(gg.mass_kg)
        inertias.append(gg.inertia_kgm2)
        rbs.append(0.5 * g.module_m * g.teeth * math.cos(g.flanks[flank].pressure_angle_rad))
        kys.append(g.support.translational_stiffness_N_per_m)
        kts.append(g.support.rotational_stiffness_Nm_per_rad)
    if table is not None:
        rbs = [float(r) for r in table.base_radius_m]
    torque = model.operating.torque_Nm
    if model.operating.torque_gear == gb.name:
        torque = torque * rbs[0] / rbs[1]
    return SpurPairParameters(
        mass_kg=tuple(masses), inertia_kg_m2=tuple(inertias), base_radius_m=tuple(rbs),
        teeth=(ga.teeth, gb.teeth), bearing_stiffness_N_per_m=tuple(kys),
        rotational_stiffness_Nm_per_rad=tuple(kts), modal_damping_ratio=model.damping.modal_damping_ratio,
        torque_Nm=torque,
    )

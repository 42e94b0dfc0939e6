"""Session hooks: print how many property-based fuzz cases ran and how they ended (tests/_fuzz.py); compile the
integration-kernel specialisations that later test modules need in a background process (tests/_warm_kernels.py)
while the first modules run.  Shared fixtures: ``helical`` (the helical_28_33 model) and ``table`` (its m12 table),
which a module may define otherwise for itself."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from _fuzz import FUZZ_COUNTS
from hacgear_core.kinds import load_model
from hacgear_core.tables import load_system_tables


@pytest.fixture(scope="module")
def helical():
    """The helical_28_33 model."""
    return load_model("helical_28_33")


@pytest.fixture(scope="module")
def table(helical):
    """helical_28_33's mesh table m12 (with its twist axis)."""
    return load_system_tables(helical.path).meshes["m12"]

# Kernel specialisations (hacgear_core.dynamics.kernels) a test compiles on a cold numba cache and that no earlier
# test compiles (measured on a cold cache: first user of each), per "<file>::<test function>": "lib:" hacgear_core's
# own, "fmu:" those of the code bundled into the FMUs (a renamed copy of hacgear_core, compiled separately).  Each
# takes about 15 s on one core.  With a cold cache the session compiles those of the collected tests in one
# background process, in the order the tests need them, while the tests before them run; a listed test waits for a
# kernel the background process has started and compiles the others itself (it claims them).  The table only moves
# work between the two cores: a kernel missing here is compiled by the test that needs it, as before; a stale entry
# costs the background process ~15 s.  HACGEAR_TEST_WARM=0 turns the background compilation off.
# Not listed on purpose: the FMU kernels of spur_28t_asym and idler_28_33_39 (fmu:_table_2_1_s2, fmu:_table_3_2_s2),
# which the FMU builds of tests/test_fmu.py's first test compile (build_fmu runs each new FMU once, in the per-user
# FMU cache, to ship the compiled code in it).
WARM_KERNELS = {
    "test_fmu.py::test_fmu_step_path_equals_library_advance": ("lib:_table_3_2_s2",),
    "test_fmu_helical.py::test_helical_fmu_equals_the_library": ("fmu:_twist_s", "lib:_twist_s"),
    "test_fmu_planetary.py::test_planetary_fmu_equals_the_library": ("fmu:_table_s2", "lib:_table_s2"),
    "test_fmu_ssp.py::test_two_stage_gearbox": ("fmu:_table_2_1_s1",),
    "test_gear_errors.py::test_runout_mesh_force_sidebands_follow_the_stiffness_variation": ("lib:_table_s2_e",),
    "test_gear_errors.py::test_helical_runout_through_the_kernel": ("lib:_twist_s_e",),
    "test_idler.py::test_chain_with_a_decoupled_third_gear_reproduces_the_spur_pair": ("lib:_table_3_2_s1",),
    "test_kernels.py::test_conventional_laws_equal_hac_for_constant_stiffness": ("lib:_linear_s1",),
    "test_kernels.py::test_specialised_and_generic_loops_agree": ("lib:_table_s1",),
    "test_kernels.py::test_coast_side_changes_nothing_while_the_drive_flanks_carry_the_load": ("lib:_table_4_1_s2",),
}
_WARM = {"proc": None, "dir": None, "log": None, "mine": set()}


def _specs(item) -> tuple[str, ...]:
    return WARM_KERNELS.get(f"{item.path.name}::{getattr(item, 'originalname', item.name)}", ())


def _claim(spec: str) -> bool:
    try:
        os.close(os.open(_WARM["dir"] / f"claim-{spec}", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        return True
    except FileExistsError:
        return False


def pytest_collection_finish(session) -> None:
    if os.environ.get("HACGEAR_TEST_WARM", "1") == "0" or session.config.option.collectonly:
        return
    order = []
    for item in session.items:
        for spec in _specs(item):
            if spec not in order:
                order.append(spec)
    if not order:
        return
    import hacgear_core

    _WARM["dir"] = Path(tempfile.mkdtemp(prefix="hacgear_warm_"))
    _WARM["log"] = open(_WARM["dir"] / "log.txt", "w")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(Path(hacgear_core.__file__).resolve().parents[1])]
                                        + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    _WARM["proc"] = subprocess.Popen([sys.executable, str(Path(__file__).with_name("_warm_kernels.py")),
                                      str(_WARM["dir"]), *order], env=env, stdin=subprocess.DEVNULL,
                                     stdout=_WARM["log"], stderr=subprocess.STDOUT)


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item) -> None:
    proc = _WARM["proc"]
    if proc is None:
        return
    for spec in _specs(item):
        if spec in _WARM["mine"] or _claim(spec):
            _WARM["mine"].add(spec)  # nobody else started it: the tests compile it
            continue
        while proc.poll() is None and not (_WARM["dir"] / f"done-{spec}").exists():
            time.sleep(0.2)


def pytest_sessionfinish(session) -> None:
    proc = _WARM["proc"]
    if proc is not None:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        _WARM["log"].close()
        _WARM["summary"] = (_WARM["dir"] / "log.txt").read_text().splitlines()
        shutil.rmtree(_WARM["dir"], ignore_errors=True)
        _WARM["proc"] = None


def pytest_terminal_summary(terminalreporter) -> None:
    if _WARM.get("summary"):
        terminalreporter.write_sep("-", "kernels compiled in the background (tests/_warm_kernels.py)")
        for line in _WARM["summary"]:
            terminalreporter.write_line(line)
    if not FUZZ_COUNTS:
        return
    terminalreporter.write_sep("-", "fuzz cases")
    for name, c in sorted(FUZZ_COUNTS.items()):
        rest = ", ".join(f"{k} {v}" for k, v in sorted(c.items()) if k != "cases")
        terminalreporter.write_line(f"{name}: {c['cases']} cases ({rest})")

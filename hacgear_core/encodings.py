"""The experiment modes and the mesh contact states, one encoding each: the simulator, the compiled kernel, the
command line's traces and the FMUs (parameter ``mode``, enumeration ``ContactState``) all use these values."""
from __future__ import annotations

from enum import IntEnum

import numpy as np

__all__ = ["Experiment", "ContactState", "CONTACT_STATE_DESCRIPTIONS", "contact_state",
           "contact_state_of"]


class Experiment(IntEnum):
    """What drives the gear train: ``SPEED`` (0) the reference gear turns at an imposed speed (constant-speed
    experiment, shaft stiffnesses of the model kept); ``TORQUE`` (1) shaft torques on the port gears, the speed
    follows from the dynamics (drivetrain coupling)."""

    SPEED = 0
    TORQUE = 1


class ContactState(IntEnum):
    """Tooth contact of one mesh: ``SEPARATED`` (0) in the backlash, ``DRIVE_FLANK`` (1) the drive flanks carry a
    force, ``COAST_FLANK`` (2) the coast flanks do (across the backlash).  FMUs name the items in lower case."""

    SEPARATED = 0
    DRIVE_FLANK = 1
    COAST_FLANK = 2


#: One sentence per contact state (the FMUs' ``ContactState`` item descriptions).
CONTACT_STATE_DESCRIPTIONS: dict[ContactState, str] = {
    ContactState.SEPARATED: "no tooth in contact: the teeth are in the backlash (drive and coast forces zero)",
    ContactState.DRIVE_FLANK: "contact on the drive flanks (mesh force > 0)",
    ContactState.COAST_FLANK: "contact on the coast flanks, across the backlash (coast force > 0)",
}


def contact_state_of(force_N: float, coast_force_N: float = 0.0) -> ContactState:
    """The contact state of one mesh from its drive-flank and coast-flank forces [N] (both >= 0)."""
    if force_N > 0.0:
        return ContactState.DRIVE_FLANK
    return ContactState.COAST_FLANK if coast_force_N > 0.0 else ContactState.SEPARATED


def contact_state(mesh_force_N, coast_force_N) -> np.ndarray:
    """:class:`ContactState` values (int8, the shape of the inputs) from drive-flank and coast-flank forces [N]
    (arrays of one shape, e.g. (records, meshes))."""
    f, fc = np.asarray(mesh_force_N), np.asarray(coast_force_N)
    return np.where(f > 0, int(ContactState.DRIVE_FLANK),
                    np.where(fc > 0, int(ContactState.COAST_FLANK), int(ContactState.SEPARATED))).astype(np.int8)

"""Options shared by the dynamics subcommands (sweep, modes, simulate)."""
from __future__ import annotations

import argparse

__all__ = ["add_model_options", "inputs_from_args"]

MODEL_HELP = ("model file models/<system>/model.toml (or its folder) with its tables.h5; a tables.h5 path; "
              "or synthetic:28t[,tip_relief_um=..,contact_ratio=..,stiffness_MN_per_m=..,variation=..,"
              "bearing_MN_per_m=..] for the synthetic demonstration table (not a contact solution)")


def add_model_options(p: argparse.ArgumentParser, torque_required: bool = True) -> None:
    p.add_argument("model", help=MODEL_HELP)
    p.add_argument("--torque", type=float, required=torque_required, default=None,
                   help="torque on gear 1 (driver) [N*m] (default: the model's [operating] torque)")
    p.add_argument("--mesh", default=None, help="mesh name (default: the first mesh)")
    p.add_argument("--tables", default=None,
                   help="tables file to use with a model file (default: tables.h5 next to the model)")
    p.add_argument("--bearing-stiffness", type=float, default=None,
                   help="override both translational bearing stiffnesses along the line of action [N/m] "
                        "(inf: rigid, purely rotational model)")
    p.add_argument("--damping-ratio", type=float, default=None,
                   help="override the modal damping ratio [-] (default: model [damping] modal_damping_ratio)")
    p.add_argument("--force-law", choices=("hac", "ste", "average_slope", "local_slope"), default="hac",
                   help="hac: force-deflection table (default); ste / average_slope / local_slope: the "
                        "conventional models of dissertation Eqs. 3.6-3.8 built from the same table")
    p.add_argument("--json", action="store_true", help="print results as JSON (SI, unit in key names)")
    p.add_argument("--ignore-model-hash", action="store_true",
                   help="experts: use a tables file whose model_sha256 does not match the model file")


def inputs_from_args(args: argparse.Namespace):
    from hacgear_core.dynamics.source import load_inputs

    return load_inputs(args.model, mesh=args.mesh, torque_Nm=args.torque,
                       bearing_stiffness_N_per_m=args.bearing_stiffness, damping_ratio=args.damping_ratio,
                       tables=args.tables, allow_hash_mismatch=args.ignore_model_hash)


def json_safe(obj):
    """Strict JSON: non-finite floats become None (NaN) or the strings "inf"/"-inf"; numpy scalars
    and arrays become Python numbers and lists."""
    import math

    import numpy as np

    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        if math.isnan(v):
            return None
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return v
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj

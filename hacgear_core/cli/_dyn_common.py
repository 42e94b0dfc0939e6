"""Options shared by the dynamics subcommands (sweep, modes, simulate)."""
from __future__ import annotations

import argparse

from hacgear_core.cli._options import check_option
from hacgear_core.cli.inputs import DynamicsInputs, load_inputs
from hacgear_core.dynamics.force_laws import FORCE_LAWS

__all__ = ["add_model_options", "inputs_from_args"]

MODEL_HELP = ("model file models/<system>/model.toml (or its folder, or a shipped system name) with its tables.h5; a "
              "tables.h5 path; or synthetic:28t[,tip_relief_um=..,contact_ratio=..,stiffness_MN_per_m=..,"
              "variation=..,bearing_MN_per_m=..] for the synthetic demonstration table (not a contact solution)")


def add_model_options(p: argparse.ArgumentParser, torque_required: bool = False) -> None:
    p.add_argument("model", help=MODEL_HELP)
    p.add_argument("--torque", type=float, required=torque_required, default=None,
                   help="torque on the input gear [N*m]" + ("" if torque_required else
                                                             " (default: the model's [operating] torque_Nm)"))
    p.add_argument("--tables", default=None,
                   help="tables file to use with a model file (default: tables.h5 next to the model)")
    p.add_argument("--bearing-stiffness", type=float, default=None,
                   help="override every gear's translational bearing stiffness [N/m] (inf: rigid, purely rotational "
                        "model, as in model files and the FMUs; 0: no bearing, a floating planetary member)")
    p.add_argument("--damping-ratio", type=float, default=None,
                   help="override the modal damping ratio [-] (default: model [damping] modal_damping_ratio)")
    p.add_argument("--force-law", choices=FORCE_LAWS, default="hac",
                   help="hac: force-deflection tables (default); ste / average_slope / local_slope: the "
                        "conventional models of dissertation Eqs. 3.6-3.8 built from the same tables")
    p.add_argument("--planets", type=int, default=None,
                   help="planetary sets: number of equally spaced planets [-] (default: the model's planet_count; "
                        "the same tables serve any count, they are per mesh kind)")
    p.add_argument("--json", action="store_true", help="print results as JSON (SI, unit in key names)")
    p.add_argument("--ignore-model-hash", action="store_true",
                   help="experts: use a tables file that does not belong to the model file (its model values differ)")


def inputs_from_args(args: argparse.Namespace, *, shafts: bool = True) -> DynamicsInputs:
    """The dynamics inputs of the model options, each checked against its range in the model schema first."""
    check_option("--torque", args.torque, "torque_Nm", signed=True)
    check_option("--damping-ratio", args.damping_ratio, "modal_damping_ratio")
    check_option("--bearing-stiffness", args.bearing_stiffness, "translational_stiffness_N_per_m")
    check_option("--planets", getattr(args, "planets", None), "planet_count")
    return load_inputs(args.model, torque_Nm=args.torque, bearing_stiffness_N_per_m=args.bearing_stiffness,
                       damping_ratio=args.damping_ratio, tables=args.tables, force_law=args.force_law,
                       allow_hash_mismatch=args.ignore_model_hash, shafts=shafts,
                       planet_count=getattr(args, "planets", None))

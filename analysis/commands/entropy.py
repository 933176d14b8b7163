"""``kruskal entropy``: the entropy after every tilt of a sequence.

From a model (``--model PATH`` or ``--automaton FILE``) and ``--sequence``: ``entropy_bits`` on
the report grid (the model's partition; on the states for an automaton without one) and
``entropy_bits_model`` on the model states. From recorded poses (``--poses FILE.csv --shape S``,
e.g. a real robot's camera log): the report-grid entropy of the ``ok`` poses at every step.
"""
from __future__ import annotations

import argparse

from analysis.commands import InputError
from analysis.commands._common import (
    add_model_source,
    add_seed,
    load_model_source,
    parse_sequence,
    sequence_rng,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_model_source(parser)
    parser.add_argument("--sequence", help='comma-separated actions, e.g. "NE,S,W", or random:N (from --seed)')
    add_seed(parser)
    parser.add_argument("--poses", metavar="FILE.csv",
                        help="recorded poses (columns trial,step,x_mm,y_mm,theta_rad[,status]) instead of a model")
    parser.add_argument("--shape", help="the shape of the recorded part (with --poses), e.g. allen-key")
    parser.add_argument("--grid", default="4x4x4", help="report grid AxBxG for --poses (default 4x4x4)")
    parser.add_argument("--theta-offset", type=float, default=None, metavar="RAD",
                        help="shift of the theta bin edges for --poses (default half a bin)")


def _from_poses(args) -> dict:
    if args.model or args.automaton:
        raise InputError("--poses cannot be combined with --model or --automaton")
    if args.sequence:
        raise InputError("--sequence is not used with --poses (the steps come from the file)")
    if not args.shape:
        raise InputError("--poses needs --shape (the report grid depends on the shape's symmetry)")
    from analysis.montecarlo import entropy_by_step, read_poses_csv, report_grid_for
    from transition_builder.scene import scene_from_options

    scene = scene_from_options(args.shape)
    grid = report_grid_for(scene, args.grid, theta_offset=args.theta_offset)
    records = read_poses_csv(args.poses)
    if records.n_steps == 0:
        raise InputError(f"poses file {args.poses!r} has no rows")
    h = entropy_by_step(records, grid)
    return {"entropy_bits": h.tolist(), "trials": records.trials, "tilts": records.n_steps - 1,
            "grid": args.grid, "shape": scene.shape.name}


def run(args: argparse.Namespace) -> dict:
    from kruskal_markov.entropy import entropy_trajectory

    if args.poses:
        return _from_poses(args)
    if args.shape:
        raise InputError("--shape is only used with --poses")
    model = load_model_source(args)
    if args.sequence is None:
        raise InputError("--sequence is required with --model or --automaton")
    rng = sequence_rng(args.seed)
    seq = parse_sequence(args.sequence, model.actions, rng)
    traj = entropy_trajectory(model, seq)
    return {
        "entropy_bits": traj.entropy_bits.tolist(),
        "entropy_bits_model": traj.entropy_bits_states.tolist(),
        "entropy_on": "partition" if model.partition is not None else "states",
        "actions": [model.actions[a] for a in seq],
        "sequence": [model.actions[a] for a in seq],
        "states": model.n_states,
        "cells": model.n_cells,
        "mass_drift": traj.mass_drift,
    }

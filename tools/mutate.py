"""Mutation testing of the core modules with mutmut (``make mutate``; docs/testing.md).

Each module is mutated in a scratch copy of the project (``build/mutate/<module>/``, ignored by
git) against only the tests that cover it, one mutant at a time (``--max-children 1`` unless
``MUTATE_JOBS`` says otherwise). mutmut leaves decorated functions alone, so the Numba
``@njit`` kernels are never mutated: the scores are for Python-level mutants only, and every
mutant reuses the compiled kernels.

    python tools/mutate.py                 # every module below
    python tools/mutate.py ensemble grid   # the named ones
    python tools/mutate.py --list
    python tools/mutate.py --recheck ensemble   # the last run's survivors against the current tests
    python tools/mutate.py --ops answers        # the operators of tools/mutate_ops.py (aggregation
                                                # swaps, constant and threshold perturbations, field
                                                # swaps); MUTATE_RANGE=a:b runs only mutants a..b-1

Prints per module: mutants, killed, survived, timeouts, score; writes the survivors' diffs to
``build/mutate/<module>/survivors.txt``. The modules with slow tests run a deterministic sample by
default (``DEFAULT_SAMPLE``: every k-th mutant in name order); ``MUTATE_SAMPLE=k`` sets k for every
module named, ``MUTATE_SAMPLE=1`` runs every mutant.

``MUTATE_PIECE=i/p`` splits one module's run into ``p`` resumable pieces (for jobs that must stay
short): piece ``i`` runs every ``p``-th mutant of the sample from the ``i``-th on. Piece 1 builds the
workspace afresh; later pieces reuse it (the same mutants and tests), so after piece ``p`` the counts
printed and ``survivors.txt`` are the whole sample's (each piece prints the pieces run so far).
"""
from __future__ import annotations

import fnmatch
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
WORK = ROOT / "build" / "mutate"

#: the simulator's fault tests without its long censuses (2,000 tilts; 16 shapes x 100 tilts), which
#: check that no fault occurs and would cost a minute per mutant
_FAULT_TESTS = [f"tests/transition_builder/test_sim_faults.py::{t}" for t in (
    "test_same_input_same_output_across_processes", "test_invalid_and_faulted_trials_are_never_poses",
    "test_escape_is_detected_without_walls_in_the_way", "test_unsettled_when_time_runs_out",
    "test_unknown_action_is_a_clear_value_error", "test_subset_action_set_indexing", "test_bad_pose_shape",
    "test_friction_map_changes_outcomes_but_stays_sane", "test_tipped_from_the_simulator_a_part_held_in_the_air_at_rest",
    "test_tipping_threshold_is_the_lift_tolerance", "test_escaped_in_flight_below_the_floor",
    "test_escaped_after_landing_from_the_simulator", "test_escaped_after_landing_by_construction",
    "test_invalid_when_the_state_goes_non_finite_in_flight", "test_fault_counts",
    "test_rest_needs_the_dwell_in_consecutive_still_intervals", "test_escape_and_tip_thresholds_by_construction",
    "test_an_invalid_start_does_not_stop_the_batch")]

#: every test file of the sync package (test_exact.py, test_shortest.py and test_trie.py were split off
#: test_searches.py; the byte step tables of sync/automaton.py are checked in test_exact.py)
_SYNC_TESTS = ["tests/kruskal_markov/sync/"]

#: the tilt-time ramp of the trial loop (``_run``, ``tilt``, ``_ramp``, its schedule ``ramp_fractions``):
#: the instant tilt unchanged, the ramp a valid landing of its own, the schedule by value, and the pair judges, whose onset judge reads the slope at which a
#: part starts to slide on a ramping tray against atan(mu_s) (the ramp's schedule), and the ramp in a trial (the
#: full tilt at its end, the rest test and the time limit from there)
_RAMP_TESTS = [f"tests/transition_builder/test_friction_pair.py::{t}" for t in (
    "test_tilt_time_zero_is_the_instant_tilt", "test_slow_tilt_changes_the_landing_but_stays_valid",
    "test_static_kinetic_judges_pass")] + ["tests/transition_builder/test_ramp_schedule.py",
                                           "tests/transition_builder/test_ramp_motion.py"]

#: module -> (file, the tests that cover it, mutant-name globs; None: every mutant of the file)
MODULES = {
    "entropy": ("kruskal_markov/entropy.py", ["tests/kruskal_markov/test_entropy.py"], None),
    "ensemble": ("kruskal_markov/ensemble.py", ["tests/kruskal_markov/test_ensemble.py"], None),
    "convergence": ("kruskal_markov/convergence.py", ["tests/kruskal_markov/test_convergence.py"], None),
    "model": ("kruskal_markov/model.py", ["tests/kruskal_markov/test_model.py"], None),
    "closed_classes": ("kruskal_markov/closed_classes.py", ["tests/kruskal_markov/test_closed_classes.py"], None),
    "automaton_json": ("kruskal_markov/automaton_json.py", ["tests/kruskal_markov/test_automaton_json.py"], None),
    "symmetry": ("transition_builder/symmetry.py", ["tests/transition_builder/test_symmetry.py"], None),
    "grid": ("transition_builder/grid.py", ["tests/transition_builder/test_grid.py"], None),
    "status": ("transition_builder/status.py", _FAULT_TESTS, None),
    "posterior": ("kruskal_markov/posterior.py", ["tests/kruskal_markov/test_posterior.py"], None),
    # the synchronizing-word search, one module per method, against the sync and plan tests
    **{f"sync_{m}": (f"kruskal_markov/sync/{m}.py", _SYNC_TESTS, None)
       for m in ("automaton", "pairs", "exact", "cost_model", "greedy", "epsilon", "targets", "plan", "result")},
    # the exact search's private helpers: the inverse depth-first phase's relabelling, its unstored
    # deepest level and its two processes, against the same tests
    **{f"sync{m}": (f"kruskal_markov/sync/{m}.py", _SYNC_TESTS, None) for m in ("_relabel", "_leaves", "_forked")},
    # the builder's assembly (counts -> model), against its unit tests on hand-made explorations
    # (test_build_model.py's physics builds read the assembled model too, but a build per mutant does not fit)
    "assembly": ("transition_builder/builder/assembly.py", ["tests/transition_builder/builder/test_assembly.py"], None),
    # the simulator: its fault classification only (the trial loop, the batch's landing check and the
    # tilt-time ramp of the loop)
    "sim": ("transition_builder/sim.py", _FAULT_TESTS + _RAMP_TESTS,
            ["transition_builder.sim.*_run__mutmut_*", "transition_builder.sim.*tilt__mutmut_*",
             "transition_builder.sim.x_valid_start__mutmut_*", "transition_builder.sim.*_ramp__mutmut_*",
             "transition_builder.sim.x_ramp_fractions__mutmut_*"]),
    # the figures the product reports: intervals, the structural term, validation and the part metrics
    "structural": ("kruskal_markov/structural.py", ["tests/kruskal_markov/test_structural_term.py", "tests/kruskal_markov/test_structural.py"], None),
    "answers": ("kruskal_markov/answers.py", ["tests/kruskal_markov/test_structural_term.py", "tests/kruskal_markov/test_answers.py"], None),
    "validate": ("analysis/validate.py", ["tests/analysis/test_validate.py", "tests/kruskal_markov/test_structural.py"], None),
    "orientability": ("analysis/orientability.py", ["tests/analysis/test_orientability.py"], None),
}

#: the default sample (every k-th mutant in name order) of the modules whose tests are slow (the
#: exhaustive searches, the Monte Carlo and pair-chain checks); ``MUTATE_SAMPLE=k`` overrides it for
#: every module named, ``MUTATE_SAMPLE=1`` runs every mutant. docs/testing.md's scores used these.
DEFAULT_SAMPLE = {"convergence": 4, "entropy": 8, "model": 8, "sync_pairs": 2, "sync_exact": 8, "sync_greedy": 8,
                  "sync_automaton": 4, "sync_epsilon": 4, "sync_targets": 2, "sync_plan": 8}

PYPROJECT = """[tool.mutmut]
source_paths = ["kruskal_markov/", "transition_builder/", "analysis/"]
only_mutate = ["{file}"]
pytest_add_cli_args_test_selection = {tests}
pytest_add_cli_args = ["-p", "no:cacheprovider", "-q", "-x"]
use_setproctitle = false
# workers forked from a clean server (the default forks from a process whose Numba state made
# children that compile a new specialisation die with SIGTERM: "suspicious", not a verdict)
process_isolation = "forkserver"
# a mutant that changes a dtype makes Numba compile a new specialisation (seconds): not a hang.
# mutmut's CPU limit is (tests' time + constant) x multiplier x 2: at least 4 minutes of CPU, so
# a mutant that loops forever (``total += 0``) costs minutes, not the 20 of a multiplier of 10
timeout_constant = 60.0
timeout_multiplier = 2.0

[tool.pytest.ini_options]
testpaths = ["tests"]
markers = ["slow: long-running tests"]
addopts = "-m 'not slow'"
"""


def _piece() -> tuple[int, int]:
    """``MUTATE_PIECE=i/p`` as ``(i, p)``; ``(1, 1)`` when unset."""
    raw = os.environ.get("MUTATE_PIECE", "1/1")
    m = re.fullmatch(r"(\d+)/(\d+)", raw)
    if not m or not 1 <= int(m.group(1)) <= int(m.group(2)):
        raise SystemExit(f"MUTATE_PIECE must be i/p with 1 <= i <= p, got {raw!r}")
    return int(m.group(1)), int(m.group(2))


def _workspace(name: str, file: str, tests: list[str], keep: bool = False) -> pathlib.Path:
    ws = WORK / name
    if keep:
        if not (ws / "pyproject.toml").exists():
            raise SystemExit(f"{ws} has no workspace to resume: run piece 1 first")
        return ws
    if ws.exists():
        shutil.rmtree(ws)
    ws.mkdir(parents=True)
    for d in ("kruskal_markov", "transition_builder", "analysis", "tests"):
        shutil.copytree(ROOT / d, ws / d, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    (ws / "pyproject.toml").write_text(PYPROJECT.format(file=file, tests=repr(tests).replace("'", '"')))
    return ws


def _results(ws: pathlib.Path, globs: list[str] | None) -> dict:
    out = subprocess.run([sys.executable, "-m", "mutmut", "results", "--all", "true"], cwd=ws,
                         capture_output=True, text=True)
    status = {}
    for line in out.stdout.splitlines():
        m = re.match(r"\s*(\S+__mutmut_\d+): (.+)$", line)
        if m and (globs is None or any(fnmatch.fnmatchcase(m.group(1), g) for g in globs)):
            status[m.group(1)] = m.group(2).strip()
    return status


def _natural(name: str):
    head, _, num = name.rpartition("_")
    return (head, int(num) if num.isdigit() else 0)


def _generate_mutants(ws: pathlib.Path, env: dict, jobs: str) -> None:
    """Let mutmut generate the workspace's mutants without running any (a pattern that matches none),
    so that their names can be listed and sampled or split."""
    subprocess.run([sys.executable, "-m", "mutmut", "run", "--max-children", jobs, "no-such-mutant"], cwd=ws,
                   env=env, capture_output=True, text=True)


def run_module(name: str) -> dict:
    file, tests, globs = MODULES[name]
    piece, pieces = _piece()
    ws = _workspace(name, file, tests, keep=piece > 1)
    # one Numba cache per module run, kept across its mutants: the kernels are never mutated, so
    # a specialisation compiled for one mutant is valid for the next
    env = dict(os.environ, NUMBA_CACHE_DIR=str(ws / ".numba-cache"))
    jobs = os.environ.get("MUTATE_JOBS", "1")
    t0 = time.perf_counter()
    pattern = [file[:-3].replace("/", ".") + ".*"] if globs is None else globs
    sample = int(os.environ.get("MUTATE_SAMPLE", DEFAULT_SAMPLE.get(name, 1)))
    if sample > 1:
        # a deterministic sample: every ``sample``-th mutant in name order (the names are known
        # once mutmut has generated the mutants; a pattern that matches none runs nothing)
        if piece == 1:                  # later pieces find the mutants generated by the first
            _generate_mutants(ws, env, jobs)
        names = sorted(_results(ws, None if globs is None else globs), key=_natural)
        names = [n for n in names if fnmatch.fnmatchcase(n, pattern[0]) or globs is not None]
        pattern = names[::sample]
        globs = pattern
    if pieces > 1:
        if globs is None:
            if piece == 1:
                _generate_mutants(ws, env, jobs)
            globs = sorted(_results(ws, pattern), key=_natural)
        # this piece's share; the counts below are over the pieces run so far ("not checked" left out)
        pattern = globs[piece - 1::pieces]
    proc = subprocess.run([sys.executable, "-m", "mutmut", "run", "--max-children", jobs, *pattern], cwd=ws,
                          env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    status = _results(ws, globs)
    counts = {}
    for s in status.values():
        counts[s] = counts.get(s, 0) + 1
    survivors = [n for n, s in status.items() if s in ("survived", "no tests", "suspicious")]
    with open(ws / "survivors.txt", "w") as fh:
        for n in survivors:
            diff = subprocess.run([sys.executable, "-m", "mutmut", "show", n], cwd=ws, capture_output=True,
                                  text=True).stdout
            fh.write(f"=== {n}\n{diff}\n")
    killed = counts.get("killed", 0) + counts.get("timeout", 0)
    # "no tests": no covering test calls the mutated function -- a survivor, counted as one
    total = sum(counts.values()) - counts.get("skipped", 0) - counts.get("not checked", 0)
    with open(WORK / "scores.jsonl", "a") as fh:
        fh.write(json.dumps({"module": name, "sample": sample, "piece": f"{piece}/{pieces}", "counts": counts,
                             "seconds": round(seconds)}) + "\n")
    label = name + (f" (1 in {sample})" if sample > 1 else "") + (f" piece {piece}/{pieces}" if pieces > 1 else "")
    row = {"module": label, "file": file,
           "mutants": sum(counts.values()), "counts": counts,
           "score": killed / total if total else float("nan"), "seconds": round(seconds),
           "returncode": proc.returncode}
    if proc.returncode not in (0,):
        row["stderr"] = proc.stderr[-1500:]
    return row


def recheck_survivors(name: str) -> dict:
    """Run the last run's survivors of ``name`` again against the current tests (in the same
    workspace, so the mutants are the same): the score after new tests."""
    file, tests, _ = MODULES[name]
    ws = WORK / name
    shutil.rmtree(ws / "tests")
    shutil.copytree(ROOT / "tests", ws / "tests", ignore=shutil.ignore_patterns("__pycache__"))
    survivors = [line[4:].strip() for line in (ws / "survivors.txt").read_text().splitlines()
                 if line.startswith("=== ")]
    meta_path = next((ws / "mutants").rglob(pathlib.Path(file).name + ".meta"))
    meta = json.loads(meta_path.read_text())
    checked = {k: v for k, v in meta["exit_code_by_key"].items() if v is not None}
    for n in survivors:
        meta["exit_code_by_key"][n] = None
    meta_path.write_text(json.dumps(meta))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(ws / ".numba-cache"))
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "mutmut", "run", "--max-children", os.environ.get("MUTATE_JOBS", "1"),
                    *survivors], cwd=ws, env=env, capture_output=True, text=True)
    status = _results(ws, list(checked))
    still = [n for n in survivors if status.get(n) in ("survived", "no tests", "suspicious")]
    with open(ws / "survivors-after.txt", "w") as fh:
        for n in still:
            diff = subprocess.run([sys.executable, "-m", "mutmut", "show", n], cwd=ws, capture_output=True,
                                  text=True).stdout
            fh.write(f"=== {n}\n{diff}\n")
    total = len(checked)
    return {"module": name, "mutants": total, "survivors_before": len(survivors), "survivors_after": len(still),
            "score_before": 1 - len(survivors) / total, "score_after": 1 - len(still) / total,
            "seconds": round(time.perf_counter() - t0)}


def main(argv: list[str]) -> int:
    if argv[:1] == ["--ops"]:
        sys.path.insert(0, str(ROOT / "tools"))
        from mutate_ops import run_ops

        for name in argv[1:] or ["structural", "answers", "validate", "orientability"]:
            file, tests, _ = MODULES[name]
            lo, _, hi = os.environ.get("MUTATE_RANGE", ":").partition(":")
            only = range(int(lo or 0), int(hi)) if hi else (range(int(lo), 10 ** 9) if lo else None)
            r = run_ops(ROOT, WORK, name, file, tests, sample=int(os.environ.get("MUTATE_SAMPLE", 1)), only=only)
            c = r["counts"]
            print(f"{name:14s} ops mutants {r['mutants']:3d}  killed {c['killed']:3d}  timeout {c['timeout']:2d}  "
                  f"survived {c['survived']:3d}  score {r['score']:.1%}", flush=True)
        return 0
    if argv[:1] == ["--recheck"]:
        for name in argv[1:]:
            r = recheck_survivors(name)
            print(f"{name:12s} mutants {r['mutants']:4d}  survivors {r['survivors_before']:3d} -> "
                  f"{r['survivors_after']:3d}  score {r['score_before']:.1%} -> {r['score_after']:.1%}  "
                  f"({r['seconds']} s)", flush=True)
        return 0
    if argv == ["--list"]:
        print("\n".join(f"{k}: {v[0]} <- {' '.join(v[1])}" for k, v in MODULES.items()))
        return 0
    names = argv or list(MODULES)
    unknown = [n for n in names if n not in MODULES]
    if unknown:
        print(f"unknown module(s) {unknown}; known: {list(MODULES)}", file=sys.stderr)
        return 2
    for name in names:
        row = run_module(name)
        c = row["counts"]
        print(f"{row['module']:18s} {row['file']:34s} mutants {row['mutants']:4d}  killed {c.get('killed', 0):4d}  "
              f"timeout {c.get('timeout', 0):3d}  survived {c.get('survived', 0):3d}  "
              f"other {sum(v for k, v in c.items() if k not in ('killed', 'timeout', 'survived')):3d}  "
              f"score {row['score']:.1%}  ({row['seconds']} s)", flush=True)
        if "stderr" in row:
            print(row["stderr"], file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

#!/usr/bin/python3
"""Runs run_sequence and evaluate_trajectory on every real camera sequence under a data folder
laid out as ../shared/data/real (doc/benchmarks.md, "Real camera sequences") and writes one
Markdown table and a JSON file with the same figures. Called by `scripts/bench real`; standard
library only. A sequence that fails gets its reason in its row; the others still run."""

import argparse
import copy
import csv
import datetime
import json
import math
import os
import platform
import re
import subprocess
import sys
import time
from pathlib import Path

MOVING_THRESHOLD_M = 0.01  # the camera "starts moving" when GT is this far from its first pose
TRACKING_STATES = ("good", "weak")
GROUND_TRUTH_NAMES = ("groundtruth_tum.txt", "groundtruth.txt")


class Sequence:
    """One sequence found under the data folder and what the benchmark measured on it."""

    def __init__(self, name, folder):
        self.name = name
        self.label = name  # in the table: the name, and the run with --runs
        self.folder = folder
        self.layout = None  # TUM, EuRoC or KITTI
        self.dataset = None  # what run_sequence gets as DATASET
        self.calibration = None  # calib.yaml, or None: the dataset's own
        self.ground_truth = None
        self.figures = {}
        self.notes = []
        self.failed = False


# --- finding the sequences -------------------------------------------------------------------


def is_kitti(folder):
    return (folder / "times.txt").is_file() and (folder / "image_0").is_dir()


def find_sequences(data_dir):
    """Every sub-folder of data_dir is a sequence (KITTI: one per sequences/NN inside it)."""
    sequences = []
    for folder in sorted(p for p in data_dir.iterdir() if p.is_dir()):
        kitti_folders = sorted(p for p in (folder / "sequences").glob("*") if is_kitti(p))
        if is_kitti(folder):
            kitti_folders.insert(0, folder)
        if kitti_folders:
            for dataset in kitti_folders:
                name = folder.name if len(kitti_folders) == 1 else f"{folder.name}/{dataset.name}"
                sequences.append(describe(Sequence(name, folder), "KITTI", dataset))
        elif (folder / "rgb.txt").is_file():
            sequences.append(describe(Sequence(folder.name, folder), "TUM", folder))
        elif (folder / "mav0" / "cam0" / "data.csv").is_file():
            sequences.append(describe(Sequence(folder.name, folder), "EuRoC", folder))
        else:
            sequence = Sequence(folder.name, folder)
            fail(sequence, "no TUM (rgb.txt), EuRoC (mav0/cam0/data.csv) or KITTI "
                           "(image_0/, times.txt) layout found")
            sequences.append(sequence)
    return sequences


def describe(sequence, layout, dataset):
    sequence.layout = layout
    sequence.dataset = dataset
    if (sequence.folder / "calib.yaml").is_file():
        sequence.calibration = sequence.folder / "calib.yaml"
    for name in GROUND_TRUTH_NAMES:
        if (sequence.folder / name).is_file():
            sequence.ground_truth = sequence.folder / name
            break
    return sequence


def fail(sequence, reason):
    sequence.failed = True
    sequence.notes.append(reason)


# --- tracking instructions per frame (--instructions) ------------------------------------------

def inline_config(config, out):
    """The parameters with the mapping thread off (system.mapping_thread: false): the run is then
    deterministic and every frame's work is the tracker's own."""
    lines = config.read_text().splitlines() if config else []
    kept, in_system, has_system = [], False, False
    for line in lines:
        top_level = line[:1] not in ("", " ", "#")
        if top_level:
            in_system = line.split(":", 1)[0].strip() == "system"
        if in_system and line.strip().startswith("mapping_thread:"):
            continue
        kept.append(line)
        if top_level and in_system:
            has_system = True
            kept.append("  mapping_thread: false")
    if not has_system:
        kept += ["system:", "  mapping_thread: false"]
    path = out / "inline_config.yaml"
    path.write_text("\n".join(kept) + "\n")
    return path


def count_instructions(sequence, bin_dir, out_dir, timeout, config=None):
    """Runs the sequence inline under callgrind, one profile dump per Tracker::processFrame, and
    keeps the median instructions of the frames that made no keyframe and of those that did:
    a count that does not depend on the machine's load (valgrind must be installed)."""
    out = out_dir / sequence.name.replace("/", "_") / "instructions"
    out.mkdir(parents=True, exist_ok=True)
    for stale in out.glob("callgrind.out*"):
        stale.unlink()
    command = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out / 'callgrind.out'}",
               # (callgrind 3.19 dumps nothing when the two patterns are the same string)
               "--toggle-collect=scale_drift_slam::tracking::Tracker::processFrame*",
               "--dump-after=*Tracker::processFrame*",
               str(bin_dir / "run_sequence"), str(sequence.dataset), "--out", str(out / "run"),
               "--quiet", "--config", str(inline_config(config, out))]
    if sequence.calibration:
        command += ["--calib", str(sequence.calibration)]
    with open(out / "valgrind.log", "w") as log:
        try:
            subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, timeout=timeout)
        except FileNotFoundError:
            sequence.notes.append("--instructions needs valgrind (apt install valgrind)")
            return
        except subprocess.TimeoutExpired:
            sequence.notes.append(f"callgrind run timed out after {timeout:.0f} s")
            return
    figures = instruction_figures(out)
    if figures is None:
        sequence.notes.append("callgrind run gave no per-frame counts (see instructions/valgrind.log)")
        return
    sequence.figures.update(figures)


def instruction_figures(out):
    """The median instructions (millions) of the tracked frames that made no keyframe and of
    those that made one, from the per-frame dumps in out (dump N: the N-th frame)."""
    per_call = {}
    for dump in out.glob("callgrind.out.*"):
        number_part = dump.name.rsplit(".", 1)[1].split("-")[0]
        if not number_part.isdigit():
            continue
        for line in dump.read_text(errors="replace").splitlines():
            if line.startswith(("summary:", "totals:")):
                per_call[int(number_part)] = int(line.split()[1])
                break
    frames_csv = out / "run" / "frames.csv"
    if not per_call or not frames_csv.exists():
        return None
    frames = read_frames_csv(frames_csv)
    ordinary, keyframe = [], []
    for call, count in per_call.items():
        if 1 <= call <= len(frames) and frames[call - 1]["state"] in TRACKING_STATES:
            made_keyframe = int(frames[call - 1].get("keyframes") or 0) > 0
            (keyframe if made_keyframe else ordinary).append(count / 1e6)
    median = lambda values: round(sorted(values)[len(values) // 2], 1) if values else None
    return {"instructions_ordinary_frame_median_m": median(ordinary),
            "instructions_keyframe_frame_median_m": median(keyframe),
            "instructions_frames": [len(ordinary), len(keyframe)]}


# --- reading the tools' outputs --------------------------------------------------------------


def read_ground_truth(path):
    """(time, x, y, z) of a TUM file ('t tx ty tz qx qy qz qw') or an EuRoC csv (t in ns).
    Raises ValueError for anything else: evaluate_trajectory reads only these two."""
    positions = []
    with open(path) as file:
        for number, line in enumerate(file, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            euroc = "," in line
            fields = line.replace(",", " ").split()
            if len(fields) < 8:
                raise ValueError(f"{path.name} line {number}: {len(fields)} fields, not TUM "
                                 "(t tx ty tz qx qy qz qw) nor EuRoC csv")
            values = [float(v) for v in fields[:4]]
            if euroc:
                values[0] *= 1e-9
            positions.append(tuple(values))
    if not positions:
        raise ValueError(f"{path.name} holds no poses")
    return sorted(positions)


def first_moving_frame(ground_truth, frame_times):
    """(index of the first frame at or after the first GT pose more than 1 cm from the first GT
    pose, largest distance from that first pose), both over the frames' time span only: a GT
    file may cover more than the images (EuRoC micro: all of V1_01)."""
    start, end = frame_times[0] - 0.05, frame_times[-1] + 0.05
    during = [p for p in ground_truth if start <= p[0] <= end]
    if not during:
        return None, None
    first = during[0][1:]
    largest = max(math.dist(p[1:], first) for p in during)
    for t, *position in during:
        if math.dist(position, first) > MOVING_THRESHOLD_M:
            later = [i for i, frame_time in enumerate(frame_times) if frame_time >= t - 1e-6]
            return (later[0] if later else None), largest
    return None, largest


def read_frames_csv(path):
    with open(path, newline="") as file:
        return list(csv.DictReader(file))


def peak_memory_mib(time_log):
    match = re.search(r"Maximum resident set size \(kbytes\): (\d+)", time_log)
    return int(match.group(1)) / 1024.0 if match else None


def last_error_line(text):
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    errors = [line for line in lines if "error" in line.lower()]
    return (errors or lines or ["no output"])[-1]


# --- running one sequence ---------------------------------------------------------------------


def run_sequence(sequence, bin_dir, out_dir, timeout, config=None, rate=0.0):
    out = out_dir / sequence.name.replace("/", "_")
    out.mkdir(parents=True, exist_ok=True)
    command = ["/usr/bin/time", "-v", "-o", str(out / "time.txt"), str(bin_dir / "run_sequence"),
               str(sequence.dataset), "--out", str(out), "--quiet"]
    if rate > 0:  # (older run_sequence builds, for comparisons, know no --rate)
        command += ["--rate", f"{rate:g}"]
    if sequence.calibration:
        command += ["--calib", str(sequence.calibration)]
    if config:
        command += ["--config", str(config)]
    for stale in ("summary.json", "frames.csv", "trajectory.txt", "evaluation.json"):
        (out / stale).unlink(missing_ok=True)
    started = time.monotonic()
    with open(out / "run.log", "w") as log:
        log.write(" ".join(command) + "\n")
        log.flush()
        try:
            status = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT,
                                    timeout=timeout).returncode
        except subprocess.TimeoutExpired:
            fail(sequence, f"run_sequence timed out after {timeout:.0f} s")
            return out
    sequence.figures["run_seconds"] = round(time.monotonic() - started, 1)
    time_log = (out / "time.txt").read_text() if (out / "time.txt").exists() else ""
    sequence.figures["peak_memory_mib"] = peak_memory_mib(time_log)
    if status != 0 or not (out / "summary.json").exists():
        fail(sequence, f"run_sequence failed (exit {status}): "
                       f"{last_error_line((out / 'run.log').read_text())}")
        return out
    summary = json.loads((out / "summary.json").read_text())
    frames = read_frames_csv(out / "frames.csv")
    figures = sequence.figures
    figures["frames"] = summary["frames"]
    # What the user keeps: the frames of the final map (trajectory.txt). Frames tracked in a
    # young map that was discarded later are counted apart, not as tracked.
    maps = summary.get("maps")  # (older run_sequence builds write no per-map figures)
    figures["tracked"] = summary.get("tracked_final_map", summary["tracked"])
    figures["tracked_percent"] = 100.0 * figures["tracked"] / max(1, summary["frames"])
    figures["tracked_in_discarded_maps"] = summary["tracked"] - figures["tracked"]
    tracked_indices = [int(f["frame"]) for f in frames if f["state"] in TRACKING_STATES]
    kept_indices = ([int(f["frame"]) for f in frames
                     if f["state"] in TRACKING_STATES and int(f.get("map", 0)) == len(maps) - 1]
                    if maps else tracked_indices)
    figures["first_tracked_frame"] = kept_indices[0] if kept_indices else None
    figures["first_tracked_frame_any_map"] = tracked_indices[0] if tracked_indices else None
    figures["frame_times"] = [float(f["timestamp"]) for f in frames]
    cpu = summary.get("timing", {}).get("tracking_cpu")
    if cpu:
        figures["tracking_cpu_median_ms"] = cpu["median_ms"]
        figures["tracking_cpu_p95_ms"] = cpu["p95_ms"]
    worker = summary.get("timing", {}).get("keyframe_worker_cpu")
    if worker:
        figures["keyframe_worker_cpu_median_ms"] = worker["median_ms"]
    figures["keyframes"] = summary.get("keyframes")
    figures["map_restarts"] = summary.get("map_restarts", 0)
    figures["relocalisations"] = summary.get("relocalisations", 0)
    figures["rejected_frames"] = summary.get("rejected_frames", 0)
    if figures["rejected_frames"]:
        sequence.notes.append(f"{figures['rejected_frames']} frames rejected")
    if figures["map_restarts"]:
        sequence.notes.append(
            f"{figures['map_restarts']} young map(s) discarded, with "
            f"{figures['tracked_in_discarded_maps']} frames tracked in them (first from frame "
            f"{figures['first_tracked_frame_any_map']}), not counted as tracked")
    if figures["relocalisations"]:
        sequence.notes.append(f"{figures['relocalisations']} relocalisation(s)")
    if not tracked_indices and frames:
        sequence.notes.append(f"never initialised; last message: '{frames[-1]['message']}'")
    return out


def evaluate(sequence, bin_dir, out):
    if not sequence.ground_truth:
        sequence.figures["ground_truth"] = None
        return
    sequence.figures["ground_truth"] = str(sequence.ground_truth)
    try:
        ground_truth = read_ground_truth(sequence.ground_truth)
    except ValueError as error:
        sequence.notes.append(f"ground truth not usable: {error}")
        return
    if sequence.figures.get("frame_times"):
        moving, largest = first_moving_frame(ground_truth, sequence.figures["frame_times"])
        sequence.figures["first_moving_frame"] = moving
        sequence.figures["ground_truth_motion_m"] = largest
    if not sequence.figures.get("tracked"):
        if sequence.figures.get("tracked_in_discarded_maps"):
            sequence.notes.append("trajectory.txt holds no poses (every map discarded): no ATE")
        return  # nothing to evaluate; the notes say why
    command = [str(bin_dir / "evaluate_trajectory"), str(sequence.ground_truth),
               str(out / "trajectory.txt"), "--json"]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0 and "holds no poses" in result.stderr:
        sequence.notes.append("trajectory.txt holds no poses (every map discarded): no ATE")
        return
    if result.returncode != 0:
        sequence.notes.append(f"evaluate_trajectory failed: {last_error_line(result.stderr)}")
        return
    (out / "evaluation.json").write_text(result.stdout)
    evaluation = json.loads(result.stdout)
    figures = sequence.figures
    path_length = evaluation["ground_truth_path_length"]
    figures["evaluated_frames"] = evaluation["frames"]["tracked"]
    figures["tracked_path_m"] = path_length
    figures["ate_rmse_m"] = evaluation["ate"]["rmse"]
    figures["ate_percent_of_path"] = (100.0 * evaluation["ate"]["rmse"] / path_length
                                      if path_length > 0 else None)
    segments = evaluation.get("scale_segments", [])
    figures["scale_per_tenth"] = [s["scale"] for s in segments]
    figures["scale_last_over_first"] = evaluation.get("scale_drift")
    # evaluate_trajectory's least-squares slope of log(scale) over the tenths' middle distances;
    # null for an evaluated path under 10 m (not extrapolated to 100 m).
    figures["drift_percent_per_100m"] = evaluation.get("scale_drift_per_100m_percent")


# --- the table ---------------------------------------------------------------------------------

COLUMNS = ["sequence", "frames", "first tracked", "moving from (GT)", "tracked", "ATE % of path",
           "scale per tenth", "drift / 100 m", "CPU median / p95", "peak memory", "notes"]
INSTRUCTION_COLUMN = "instructions per frame (inline): ordinary / keyframe"


def number(value, digits=1, unit=""):
    return "-" if value is None else f"{value:.{digits}f}{unit}"


def table_row(sequence, with_instructions=False):
    f = sequence.figures
    frames = f.get("frames")
    tracked = "-" if frames is None else f"{f['tracked']}/{frames} ({f['tracked_percent']:.1f} %)"
    ate = number(f.get("ate_percent_of_path"), 2, " %")
    if f.get("tracked_path_m") is not None:
        ate += f" of {f['tracked_path_m']:.2f} m ({f['evaluated_frames']} poses)"
    scales = " ".join(f"{s:.2f}" for s in f.get("scale_per_tenth", [])) or "-"
    moving = number(f.get("first_moving_frame"), 0)
    if f.get("first_moving_frame") is None and f.get("ground_truth_motion_m") is not None:
        moving = f"none (GT moves {100 * f['ground_truth_motion_m']:.1f} cm)"
    drift = f.get("drift_percent_per_100m")
    drift = "-" if drift is None else f"{drift:+.1f} %"
    cpu = ("-" if f.get("tracking_cpu_median_ms") is None else
           f"{f['tracking_cpu_median_ms']:.1f} / {f['tracking_cpu_p95_ms']:.1f} ms")
    if f.get("keyframe_worker_cpu_median_ms") is not None:
        cpu += f" (+ {f['keyframe_worker_cpu_median_ms']:.1f} ms per keyframe in the worker)"
    cells = [sequence.label, "-" if frames is None else str(frames),
             number(f.get("first_tracked_frame"), 0), moving,
             tracked, ate, scales, drift, cpu, number(f.get("peak_memory_mib"), 0, " MiB")]
    if with_instructions:
        counts = f.get("instructions_frames", [0, 0])
        cells.append(f"{number(f.get('instructions_ordinary_frame_median_m'), 1, ' M')} "
                     f"({counts[0]} frames) / "
                     f"{number(f.get('instructions_keyframe_frame_median_m'), 1, ' M')} "
                     f"({counts[1]})")
    cells.append(("**failed**: " if sequence.failed else "") + "; ".join(sequence.notes))
    return "| " + " | ".join(c.replace("|", "/").replace("\n", " ") for c in cells) + " |"


def git_commit(root):
    result = subprocess.run(["git", "-C", str(root), "describe", "--always", "--dirty"],
                            capture_output=True, text=True)
    return result.stdout.strip() or "unknown"


def header(arguments):
    cpu_model = "unknown"
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            cpu_model = line.split(":", 1)[1].strip()
            break
    return [
        f"# Real camera sequences, {datetime.datetime.utcnow():%Y-%m-%dT%H:%MZ}",
        f"Data: `{arguments.data}`; binaries: `{arguments.bin_dir}`; scripts at "
        f"{git_commit(arguments.root)}; {os.cpu_count()} cores ({cpu_model}, "
        f"{platform.machine()}), "
        f"load average {os.getloadavg()[0]:.1f} at the start"
        f"{f'; parameters `{arguments.config}`' if arguments.config else ''}; frames fed "
        f"{'as fast as tracking goes' if arguments.rate <= 0 else f'at {arguments.rate:g} x their rate'}"
        f" (--rate {arguments.rate:g}).",
        "",
    ]


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--data", type=Path, required=True, help="folder of sequence folders")
    parser.add_argument("--out", type=Path, required=True, help="Markdown table (JSON beside it)")
    parser.add_argument("--bin-dir", type=Path, required=True,
                        help="folder with run_sequence and evaluate_trajectory")
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent)
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds per sequence")
    parser.add_argument("--config", type=Path, help="parameter file for run_sequence (--config)")
    parser.add_argument("--rate", type=float, default=0.0,
                        help="run_sequence --rate: 0 (default) feeds the frames as fast as "
                             "tracking goes, 1 at their camera's rate, as a live camera would")
    parser.add_argument("--instructions", action="store_true",
                        help="also run each sequence inline under callgrind and give the "
                             "median tracking instructions of a frame with and without a "
                             "keyframe (independent of the machine's load; needs valgrind)")
    parser.add_argument("--runs", type=int, default=1,
                        help="runs of each sequence, one row each (threaded runs differ: the "
                             "mapper's updates land at other frames)")
    arguments = parser.parse_args()
    if arguments.runs < 1:
        sys.exit("bench_real.py: --runs must be >= 1")
    if not arguments.rate >= 0:
        sys.exit("bench_real.py: --rate must be >= 0 (0: as fast as tracking goes)")
    if not arguments.data.is_dir():
        sys.exit(f"bench_real.py: no data folder '{arguments.data}'")
    arguments.out.parent.mkdir(parents=True, exist_ok=True)
    runs_dir = arguments.out.with_suffix("")  # real.md -> real/<sequence>/
    lines = header(arguments)
    found = find_sequences(arguments.data)
    sequences = []  # one per run: with --runs N, each sequence N times, its rows together
    for sequence in found:
        for run in range(1, arguments.runs + 1):
            this_run = copy.deepcopy(sequence)
            out_dir = runs_dir
            if arguments.runs > 1:
                this_run.label = f"{sequence.name} (run {run})"
                out_dir = runs_dir / f"run{run}"
            sequences.append(this_run)
            if this_run.failed:
                continue
            print(f"[bench real] {this_run.label} ({this_run.layout})", flush=True)
            out = run_sequence(this_run, arguments.bin_dir, out_dir, arguments.timeout,
                               arguments.config, arguments.rate)
            if not this_run.failed:
                evaluate(this_run, arguments.bin_dir, out)
            if arguments.instructions and run == 1 and not this_run.failed:
                count_instructions(this_run, arguments.bin_dir, out_dir,
                                   arguments.timeout * 20, arguments.config)
            print("  " + table_row(this_run, arguments.instructions), flush=True)
    columns = COLUMNS[:-1] + ([INSTRUCTION_COLUMN] if arguments.instructions else []) + ["notes"]
    lines.append("| " + " | ".join(columns) + " |")
    lines.append("|" + "---|" * len(columns))
    lines += [table_row(s, arguments.instructions) for s in sequences]
    lines.append("")
    lines.append(f"Per-sequence outputs (run.log, time.txt, frames.csv, summary.json, "
                 f"evaluation.json) in `{runs_dir}/`.")
    arguments.out.write_text("\n".join(lines) + "\n")
    results = []
    for s in sequences:
        figures = {k: v for k, v in s.figures.items() if k != "frame_times"}
        results.append({"sequence": s.name, "label": s.label, "layout": s.layout,
                        "dataset": str(s.dataset) if s.dataset else None,
                        "calibration": str(s.calibration) if s.calibration else "dataset's own",
                        "failed": s.failed, "notes": s.notes, **figures})
    arguments.out.with_suffix(".json").write_text(json.dumps(
        {"header": lines[:2], "sequences": results}, indent=2) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()

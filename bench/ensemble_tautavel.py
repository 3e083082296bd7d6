"""The Tautavel ensemble (pipelines/tautavel_ensemble.yaml: 32 members, each a climate-run of
the sample valley at 60 m, 128 × 128 cells, back to 814 ka in 407 steps of 2000 y, then
compare-terraces) timed three ways on this machine:

* ``serial``: ``--workers 1``, the members one after the other in one worker process, each
  with every core for its numba threads;
* ``local cluster``: the default ``LocalCluster`` (one worker a core, one numba thread each);
* ``scheduler + 2 workers``: a ``dask scheduler`` and two ``dask worker --nthreads 1`` started
  by hand on localhost, the ensemble given ``--scheduler``.

Each run writes its own folder; the kernels are compiled (or loaded) by one climate-run first.
The wall times, the members' summed run times (their done markers) and the speed-ups against
serial are printed as JSON; the three ensembles' members.csv must rank the same scores (the
results do not depend on how the members are spread).

    .venv/bin/python bench/ensemble_tautavel.py [WORK_FOLDER] [--members N]
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "pipelines" / "tautavel_ensemble.yaml"
SAMPLE = ROOT / "sample_dems" / "valley_utm32n_30m.tif"
BIN = Path(sys.executable).parent


def cli(*args: object) -> None:
    subprocess.run([sys.executable, "-m", "unerode_cli", *map(str, args)], check=True)


def ensemble(work: Path, name: str, members: int, *engine: object) -> dict[str, float]:
    """Run the ensemble into ``work/name``; its wall time (s) and members' summed run times."""
    out = work / name
    start = time.perf_counter()
    cli("ensemble", SPEC, out, "--members", members, "--seed", 1, "--var", f"dem={work / 'valley_60m.tif'}",
        "--data", work, "--overwrite", "-qq", *engine)
    wall = time.perf_counter() - start
    busy = sum(json.loads(done.read_text())["wall_s"] for done in out.glob("members/*/done.json"))
    return {"wall_s": round(wall, 1), "members_busy_s": round(busy, 1),
            "members": len(list(out.glob("members/*/done.json")))}


def scores(work: Path, name: str) -> list[str]:
    with (work / name / "members.csv").open() as handle:
        return sorted(row.get("terrace_rmse_m", "") for row in csv.DictReader(handle))


def main(work: Path, members: int) -> dict[str, object]:
    work.mkdir(parents=True, exist_ok=True)
    dem = work / "valley_60m.tif"
    if not dem.exists():
        cli("convert", SAMPLE, dem, "--cell-size", 60, "-q")
    cli("climate-run", dem, work / "warm.tif", "--chronology", ROOT.parent / "shared/data/lr04/LR04stack.txt",
        "--to", 20, "--dt", 2000, "--process", "thermal,fluvial", "--overwrite", "-qq")
    result: dict[str, object] = {"cores": os.cpu_count()}
    result["serial"] = ensemble(work, "serial", members, "--workers", 1)
    result["local cluster"] = ensemble(work, "local", members)
    scheduler = subprocess.Popen([BIN / "dask", "scheduler", "--host", "127.0.0.1", "--port", "8799",
                                  "--dashboard-address", ":0"], stderr=subprocess.DEVNULL,
                                 start_new_session=True)
    workers = [subprocess.Popen([BIN / "dask", "worker", "tcp://127.0.0.1:8799", "--nthreads", "1",
                                 "--local-directory", str(work / f"dask{i}")],
                                stderr=subprocess.DEVNULL, start_new_session=True,
                                env={**os.environ, "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"})
               for i in range(2)]
    try:
        time.sleep(5)
        result["scheduler + 2 workers"] = ensemble(work, "scheduler", members,
                                                   "--scheduler", "tcp://127.0.0.1:8799")
    finally:
        for process in [*workers, scheduler]:
            os.killpg(process.pid, signal.SIGTERM)
    serial = result["serial"]["wall_s"]
    for name in ("local cluster", "scheduler + 2 workers"):
        result[name]["speed_up_vs_serial"] = round(serial / result[name]["wall_s"], 2)
    result["same scores"] = scores(work, "serial") == scores(work, "local") == scores(work, "scheduler")
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("work", nargs="?", type=Path,
                        default=Path(tempfile.mkdtemp(prefix="unerode-tautavel-ensemble-")))
    parser.add_argument("--members", type=int, default=8, help="Latin hypercube samples (× 4 lists)")
    arguments = parser.parse_args()
    print(json.dumps(main(arguments.work, arguments.members), indent=1))
